// Culling triangles outside a ray bucket (Carr, Hall, Hart 2002, sec. 5.3, last paragraph: "We
// also used the vertex shader to cull ... triangles outside the ray bucket from intersection
// consideration"). A bucket of rays sent to the GPU kernel gets a conservative bound of every
// point where its rays can meet the triangles sent with it; a triangle whose bounding box
// cannot meet that bound is moved off screen in shaders/raytrace/raster_intersect.vert, so no
// fragment (ray-triangle test) runs for it.
//
// THE GLSL TWIN of bucketMayReach() is shaders/common/bucket_cull.glsl: same operations in the
// same order; change both together (BucketCull.GlslTwinAgreesWithCpp checks that they agree).
//
// The bound, built on the CPU by boundRayBucket() from the rays as they are uploaded:
//  - the reach box: the box of every ray's chord, the segment o + t d for t in [tmin, far]
//    (far: the kernel's far bound, beyond which it discards hits) clipped to the clip box, the
//    box of the triangles of the pass (a hit lies on a triangle, so inside it);
//  - the beam (a two-plane bound, as for light fields), when no direction is parallel to the
//    two faces of the reach box across some axis a: each ray's line crosses the face p_a = c0
//    at q0 and the face p_a = c1 at q1, and between them it is p = (1 - s) q0 + s q1 with
//    s = (p_a - c0) / (c1 - c0) in [0, 1]. With q0 and q1 in the boxes [q0_lo, q0_hi] and
//    [q1_lo, q1_hi] (the other two coordinates) over the bucket, a point of the bucket's rays at
//    p_a lies in (1 - s) [q0_lo, q0_hi] + s [q1_lo, q1_hi]; the test takes the hull of that
//    over the part of the triangle's box inside the reach box (linear in s: its two ends). Of
//    the axes where it exists the one with the narrowest faces is taken. The bound is tight
//    for a bucket from a small patch (a cone) and for a pencil of nearly parallel rays,
//    wherever their origins lie along it.
//
// Conservative by construction: the bound is built in double and every part is widened by
// kBucketPad of the largest coordinate magnitude (q0 and q1 by (1 + 4 max |d_b / d_a|) times
// that), which covers the float rounding of the test (about 1e-7 relative) and the kernel's own
// acceptance of hits a rounding error outside a triangle, with two orders of magnitude to
// spare. A triangle any ray of the bucket hits is never culled
// (BucketCull.NeverCullsATriangleARayHits), so the kernel's answers are exactly those without
// culling. A non-finite ray switches culling off for its bucket.
#pragma once

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>

namespace penumbra {

// What a bound allows (the `mode` uniform of bucket_cull.glsl).
enum class BucketCullMode : int32_t {
  kKeepAll = 0,  // no bound (non-finite rays): every triangle is tested
  kBox = 1,      // the reach box only
  kBeam = 2,     // the reach box and the beam along `axis`
  kCullAll = 3,  // no ray can reach the clip box: every triangle is culled
};

// Relative widening of every bound (see above).
constexpr float kBucketPad = 1e-5f;

// The bound of one bucket; uploaded as the uniform struct `bucket` of raster_intersect.vert
// (setBucketBoundUniforms in ray_engine_gl.h). The two faces of the beam are c0 =
// reach_lo[axis] and c1 = reach_hi[axis].
struct RayBucketBound {
  glm::vec3 reach_lo{0.0f}, reach_hi{0.0f};  // box of the rays' chords in the clip box
  glm::vec3 q0_lo{0.0f}, q0_hi{0.0f};        // kBeam: where the lines cross p_a = c0 (b != a)
  glm::vec3 q1_lo{0.0f}, q1_hi{0.0f};        // and p_a = c1
  BucketCullMode mode = BucketCullMode::kKeepAll;
  int32_t axis = 0;         // kBeam: a
  float inv_length = 0.0f;  // kBeam: 1 / (c1 - c0)
};

// The steps of boundRayBucket (below).
namespace detail {

inline constexpr double kBucketHuge = std::numeric_limits<double>::max();

// The largest coordinate magnitude of the clip box.
inline double clipMagnitude(const glm::vec3& clip_lo, const glm::vec3& clip_hi) {
  double magnitude = 0.0;
  for (int a = 0; a < 3; ++a) {
    magnitude = std::max({magnitude, std::fabs(double(clip_lo[a])), std::fabs(double(clip_hi[a]))});
  }
  return magnitude;
}

// Ray (o, d)'s chord [t0, t1] in the clip box widened by the pad (so that rounding never
// shortens one); false when the ray cannot meet a triangle there.
inline bool rayChord(const glm::vec4& o, const glm::vec4& d, const glm::vec3& clip_lo,
                     const glm::vec3& clip_hi, double clip_pad, double& t0, double& t1) {
  t0 = o.w, t1 = d.w;
  if (!(t1 >= t0) || (d.x == 0.0f && d.y == 0.0f && d.z == 0.0f)) return false;
  for (int a = 0; a < 3; ++a) {
    const double lo = double(clip_lo[a]) - clip_pad, hi = double(clip_hi[a]) + clip_pad;
    if (d[a] == 0.0f) {
      if (o[a] < lo || o[a] > hi) return false;  // parallel to the slab and outside it
      continue;
    }
    const double ta = (lo - o[a]) / d[a], tb = (hi - o[a]) / d[a];
    t0 = std::max(t0, std::min(ta, tb));
    t1 = std::min(t1, std::max(ta, tb));
  }
  return t0 <= t1;
}

// What the first pass finds over a bucket's rays.
struct BucketReach {
  double lo[3] = {kBucketHuge, kBucketHuge, kBucketHuge};
  double hi[3] = {-kBucketHuge, -kBucketHuge, -kBucketHuge};
  double max_slope[3] = {0.0, 0.0, 0.0};  // per axis a: the largest |d_b / d_a|
  bool nonzero[3] = {true, true, true};   // no direction so far has d_a = 0
  size_t rays = 0;                        // rays with a chord
};

// First pass: chords, the reach box, and the axes no direction is perpendicular to. False when
// some ray is not finite.
inline bool reachOfRays(std::span<const glm::vec4> origins, std::span<const glm::vec4> directions,
                        const glm::vec3& clip_lo, const glm::vec3& clip_hi, double clip_pad,
                        BucketReach& r) {
  for (size_t i = 0; i < origins.size(); ++i) {
    for (int k = 0; k < 4; ++k) {
      if (!std::isfinite(origins[i][k]) || !std::isfinite(directions[i][k])) return false;
    }
    const glm::vec4 o = origins[i], d = directions[i];
    double t0, t1;
    if (!rayChord(o, d, clip_lo, clip_hi, clip_pad, t0, t1)) continue;
    ++r.rays;
    for (int a = 0; a < 3; ++a) {
      const double e0 = o[a] + t0 * d[a], e1 = o[a] + t1 * d[a];
      r.lo[a] = std::min({r.lo[a], e0, e1});
      r.hi[a] = std::max({r.hi[a], e0, e1});
      r.nonzero[a] = r.nonzero[a] && d[a] != 0.0f;
      if (!r.nonzero[a]) continue;
      for (int k = 0; k < 3; ++k) {
        if (k == a) continue;
        r.max_slope[a] = std::max(r.max_slope[a], std::fabs(double(d[k]) / double(d[a])));
      }
    }
  }
  return true;
}

// The boxes [lo[a][f], hi[a][f]] of the other two coordinates where the bucket's lines cross
// face f of the reach box across axis a (f = 0 at reach_lo[a], 1 at reach_hi[a]).
struct BeamFaces {
  double lo[3][2][3], hi[3][2][3];  // [a][face][b]
};

// Second pass: where the lines cross the two faces across each candidate axis (the faces as
// stored in float, in b, which the test measures from).
inline void crossFaces(std::span<const glm::vec4> origins, std::span<const glm::vec4> directions,
                       const glm::vec3& clip_lo, const glm::vec3& clip_hi, double clip_pad,
                       const bool (&nonzero)[3], const RayBucketBound& b, BeamFaces& q) {
  for (int a = 0; a < 3; ++a) {
    for (int f = 0; f < 2; ++f) {
      for (int k = 0; k < 3; ++k) q.lo[a][f][k] = kBucketHuge, q.hi[a][f][k] = -kBucketHuge;
    }
  }
  for (size_t i = 0; i < origins.size(); ++i) {
    const glm::vec4 o = origins[i], d = directions[i];
    double t0, t1;
    if (!rayChord(o, d, clip_lo, clip_hi, clip_pad, t0, t1)) continue;
    for (int a = 0; a < 3; ++a) {
      if (!nonzero[a]) continue;
      for (int f = 0; f < 2; ++f) {
        const double c = f == 0 ? double(b.reach_lo[a]) : double(b.reach_hi[a]);
        const double t = (c - double(o[a])) / double(d[a]);
        for (int k = 0; k < 3; ++k) {
          if (k == a) continue;
          const double p = double(o[k]) + t * double(d[k]);
          q.lo[a][f][k] = std::min(q.lo[a][f][k], p);
          q.hi[a][f][k] = std::max(q.hi[a][f][k], p);
        }
      }
    }
  }
}

// The axis with the narrowest faces (sum of the four widths, in scene units): b becomes a beam
// along it, if any axis qualifies.
inline void chooseBeamAxis(const BucketReach& r, const BeamFaces& q, RayBucketBound& b) {
  double best = kBucketHuge;
  for (int a = 0; a < 3; ++a) {
    if (!r.nonzero[a] || !(b.reach_hi[a] > b.reach_lo[a]) || !(r.max_slope[a] < 1e6)) continue;
    double width = 0.0;
    for (int f = 0; f < 2; ++f) {
      for (int k = 0; k < 3; ++k) width += k == a ? 0.0 : q.hi[a][f][k] - q.lo[a][f][k];
    }
    if (!(width < best)) continue;
    best = width;
    b.mode = BucketCullMode::kBeam;
    b.axis = a;
  }
}

// The beam's faces along b.axis, widened by pad (1 + 4 max |d_b / d_a|).
inline void setBeamFaces(const BucketReach& r, const BeamFaces& q, double pad, RayBucketBound& b) {
  const int a = b.axis;
  b.inv_length = 1.0f / (b.reach_hi[a] - b.reach_lo[a]);
  const double q_pad = pad * (1.0 + 4.0 * r.max_slope[a]);
  for (int k = 0; k < 3; ++k) {
    if (k == a) continue;
    b.q0_lo[k] = float(q.lo[a][0][k] - q_pad);
    b.q0_hi[k] = float(q.hi[a][0][k] + q_pad);
    b.q1_lo[k] = float(q.lo[a][1][k] - q_pad);
    b.q1_hi[k] = float(q.hi[a][1][k] + q_pad);
  }
}

}  // namespace detail

// The bound of rays i < origins.size() given as the kernel's textures hold them: origins[i] =
// (o, tmin), directions[i] = (d, far); a ray with far < tmin or d = 0 can hit nothing in the
// kernel (n . d = 0) and is left out. [clip_lo, clip_hi] holds every triangle to be tested.
// Contract: directions.size() >= origins.size().
inline RayBucketBound boundRayBucket(std::span<const glm::vec4> origins,
                                     std::span<const glm::vec4> directions,
                                     const glm::vec3& clip_lo, const glm::vec3& clip_hi) {
  RayBucketBound b;
  double magnitude = detail::clipMagnitude(clip_lo, clip_hi);
  if (!std::isfinite(magnitude)) return b;  // kKeepAll
  const double clip_pad =
      double(kBucketPad) * magnitude + double(std::numeric_limits<float>::min());
  detail::BucketReach reach;
  if (!detail::reachOfRays(origins, directions, clip_lo, clip_hi, clip_pad, reach)) {
    return RayBucketBound{};  // kKeepAll
  }
  if (reach.rays == 0) {
    b.mode = BucketCullMode::kCullAll;
    return b;
  }
  // The reach box, padded.
  for (int a = 0; a < 3; ++a) {
    magnitude = std::max({magnitude, std::fabs(reach.lo[a]), std::fabs(reach.hi[a])});
  }
  const double pad = double(kBucketPad) * magnitude + double(std::numeric_limits<float>::min());
  for (int a = 0; a < 3; ++a) {
    b.reach_lo[a] = float(reach.lo[a] - pad);
    b.reach_hi[a] = float(reach.hi[a] + pad);
  }
  b.mode = BucketCullMode::kBox;
  // The beam, where some axis allows one.
  detail::BeamFaces faces;
  detail::crossFaces(origins, directions, clip_lo, clip_hi, clip_pad, reach.nonzero, b, faces);
  detail::chooseBeamAxis(reach, faces, b);
  if (b.mode != BucketCullMode::kBeam) return b;
  detail::setBeamFaces(reach, faces, pad, b);
  return b;
}

// Can some ray of the bucket reach a point of the box [lo, hi] (a triangle's bounding box, inside
// the clip box)? False only when none can: the triangle is culled. The GLSL twin is
// bucketMayReach in shaders/common/bucket_cull.glsl.
inline bool bucketMayReach(const RayBucketBound& b, const glm::vec3& lo, const glm::vec3& hi) {
  if (b.mode == BucketCullMode::kKeepAll) return true;
  if (b.mode == BucketCullMode::kCullAll) return false;
  // The reach box.
  if (lo.x > b.reach_hi.x || lo.y > b.reach_hi.y || lo.z > b.reach_hi.z) return false;
  if (hi.x < b.reach_lo.x || hi.y < b.reach_lo.y || hi.z < b.reach_lo.z) return false;
  if (b.mode != BucketCullMode::kBeam) return true;
  // The beam: s at the two ends of the part of the box inside the reach box.
  const int a = b.axis;
  const float s0 =
      std::clamp((std::max(lo[a], b.reach_lo[a]) - b.reach_lo[a]) * b.inv_length, 0.0f, 1.0f);
  const float s1 =
      std::clamp((std::min(hi[a], b.reach_hi[a]) - b.reach_lo[a]) * b.inv_length, 0.0f, 1.0f);
  for (int k = 0; k < 3; ++k) {
    if (k == a) continue;
    // The hull of (1 - s) [q0_lo, q0_hi] + s [q1_lo, q1_hi] for s in [s0, s1].
    const float lo_dq = b.q1_lo[k] - b.q0_lo[k], hi_dq = b.q1_hi[k] - b.q0_hi[k];
    const float beam_lo = std::min(b.q0_lo[k] + s0 * lo_dq, b.q0_lo[k] + s1 * lo_dq);
    const float beam_hi = std::max(b.q0_hi[k] + s0 * hi_dq, b.q0_hi[k] + s1 * hi_dq);
    if (beam_lo > std::min(hi[k], b.reach_hi[k]) || beam_hi < std::max(lo[k], b.reach_lo[k])) {
      return false;
    }
  }
  return true;
}

}  // namespace penumbra
