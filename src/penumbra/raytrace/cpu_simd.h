// The CPU back end's inner loops: one ray against the eight child boxes of a wide node, and one
// ray against a block of up to eight triangles. Each comes twice: with AVX2 (compiled for AVX2
// whatever the build's target, through PENUMBRA_AVX2_TARGET, and used only when the CPU has it:
// see cpuHasAvx2) and as a portable scalar loop. Both give bit-for-bit the same answers: the
// slab test, and the watertight test of kernels/ray_triangle.h, in the same order of
// operations.
#pragma once

#include "penumbra/accel/wide_bvh.h"
#include "penumbra/kernels/ray_triangle.h"

#include <glm/vec3.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define PENUMBRA_HAVE_AVX2_KERNELS 1
// Functions that use AVX2 and FMA intrinsics, whatever -march the build uses.
#define PENUMBRA_AVX2_TARGET __attribute__((target("avx2,fma,bmi,bmi2,popcnt,lzcnt")))
#else
#define PENUMBRA_HAVE_AVX2_KERNELS 0
#define PENUMBRA_AVX2_TARGET
#endif

namespace penumbra {

// Whether this CPU runs the AVX2 kernels (checked once, at run time).
inline bool cpuHasAvx2() {
#if PENUMBRA_HAVE_AVX2_KERNELS
  static const bool has = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") &&
                          __builtin_cpu_supports("bmi2") && __builtin_cpu_supports("popcnt");
  return has;
#else
  return false;
#endif
}

// 1 / d with zero components replaced by +-1e-30, so slab distances stay finite (no 0 * inf NaN).
// A tiny component only makes a box test more conservative, never culls a box the ray enters.
inline float safeReciprocal(float d) {
  return 1.0f / (std::fabs(d) < 1e-30f ? std::copysign(1e-30f, d) : d);
}

// Rounding margin for the far slab distance, 1 + 2 gamma(3), so rounding never culls a box the
// ray touches (Ize, "Robust BVH Ray Traversal", JCGT 2(2), 2013).
inline constexpr float kFarScale = 1.0000004f;

// Slab tests of one ray against the eight child boxes of a node.
struct BoxTester {
  glm::vec3 org, inv;
  bool neg_x, neg_y, neg_z;

  BoxTester() = default;
  BoxTester(const glm::vec3& o, const glm::vec3& d)
      : org(o),
        inv(safeReciprocal(d.x), safeReciprocal(d.y), safeReciprocal(d.z)),
        neg_x(inv.x < 0.0f),
        neg_y(inv.y < 0.0f),
        neg_z(inv.z < 0.0f) {}

  // The quantised node's planes (accel/wide_bvh.h): the byte arrays of the near and far
  // planes per axis, chosen by the direction's sign as for float boxes.
  struct QPlanes {
    const uint8_t *nx, *fx, *ny, *fy, *nz, *fz;
  };
  QPlanes planes(const Bvh8QNode& n) const {
    return {neg_x ? n.hi_x : n.lo_x, neg_x ? n.lo_x : n.hi_x, neg_y ? n.hi_y : n.lo_y,
            neg_y ? n.lo_y : n.hi_y, neg_z ? n.hi_z : n.lo_z, neg_z ? n.lo_z : n.hi_z};
  }

  // Bit i is set when child i is entered within [tmin, tmax]; t_near gets the entry distances.
  // A plane is origin + q * scale (exact product, one rounding), then the same slab arithmetic
  // as a float box's.
#if PENUMBRA_HAVE_AVX2_KERNELS
  PENUMBRA_AVX2_TARGET static __m256 planeAvx2(const uint8_t* q, float origin, float scale) {
    const __m256 qf = _mm256_cvtepi32_ps(
        _mm256_cvtepu8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(q))));
    return _mm256_add_ps(_mm256_mul_ps(qf, _mm256_set1_ps(scale)), _mm256_set1_ps(origin));
  }

  PENUMBRA_AVX2_TARGET uint32_t testAvx2(const Bvh8QNode& n, float tmin, float tmax,
                                         float* t_near) const {
    const QPlanes pl = planes(n);
    const __m256 ox = _mm256_set1_ps(org.x), oy = _mm256_set1_ps(org.y);
    const __m256 oz = _mm256_set1_ps(org.z);
    const __m256 ix = _mm256_set1_ps(inv.x), iy = _mm256_set1_ps(inv.y);
    const __m256 iz = _mm256_set1_ps(inv.z);
    const float *o = n.origin, *s = n.scale;
    const __m256 tnx = _mm256_mul_ps(_mm256_sub_ps(planeAvx2(pl.nx, o[0], s[0]), ox), ix);
    const __m256 tny = _mm256_mul_ps(_mm256_sub_ps(planeAvx2(pl.ny, o[1], s[1]), oy), iy);
    const __m256 tnz = _mm256_mul_ps(_mm256_sub_ps(planeAvx2(pl.nz, o[2], s[2]), oz), iz);
    const __m256 tfx = _mm256_mul_ps(_mm256_sub_ps(planeAvx2(pl.fx, o[0], s[0]), ox), ix);
    const __m256 tfy = _mm256_mul_ps(_mm256_sub_ps(planeAvx2(pl.fy, o[1], s[1]), oy), iy);
    const __m256 tfz = _mm256_mul_ps(_mm256_sub_ps(planeAvx2(pl.fz, o[2], s[2]), oz), iz);
    const __m256 tn =
        _mm256_max_ps(_mm256_max_ps(tnx, tny), _mm256_max_ps(tnz, _mm256_set1_ps(tmin)));
    const __m256 tf = _mm256_mul_ps(
        _mm256_min_ps(_mm256_min_ps(tfx, tfy), _mm256_min_ps(tfz, _mm256_set1_ps(tmax))),
        _mm256_set1_ps(kFarScale));
    _mm256_store_ps(t_near, tn);
    return uint32_t(_mm256_movemask_ps(_mm256_cmp_ps(tn, tf, _CMP_LE_OQ))) & n.valid;
  }
#endif

  uint32_t testScalar(const Bvh8QNode& n, float tmin, float tmax, float* t_near) const {
    const QPlanes pl = planes(n);
    const float *o = n.origin, *s = n.scale;
    const auto plane = [](uint8_t q, float origin, float scale) {
      return origin + float(q) * scale;
    };
    uint32_t mask = 0;
    for (int i = 0; i < 8; ++i) {
      // The order of max/min matches the AVX2 version (max(max(x, y), max(z, tmin))).
      const float tn = std::max(std::max((plane(pl.nx[i], o[0], s[0]) - org.x) * inv.x,
                                         (plane(pl.ny[i], o[1], s[1]) - org.y) * inv.y),
                                std::max((plane(pl.nz[i], o[2], s[2]) - org.z) * inv.z, tmin));
      const float tf = std::min(std::min((plane(pl.fx[i], o[0], s[0]) - org.x) * inv.x,
                                         (plane(pl.fy[i], o[1], s[1]) - org.y) * inv.y),
                                std::min((plane(pl.fz[i], o[2], s[2]) - org.z) * inv.z, tmax)) *
                       kFarScale;
      t_near[i] = tn;
      mask |= uint32_t(tn <= tf) << i;
    }
    return mask & n.valid;
  }
};

#if PENUMBRA_HAVE_AVX2_KERNELS
// The second half of the watertight test (Woop et al. 2013, sec. 3) on eight lanes, each a
// (ray, triangle) pair whose three vertices are already translated to the ray origin and
// sheared (px, py: the sheared x and y; pz: the unsheared z, scaled here by sz). Same operations
// in the same order as intersectTriangle(), so each lane's t, u, v are bit-identical to it.
// `ok` marks lanes hit within [tmin, tmax]; `on_edge` marks lanes where an edge function is
// exactly zero, which the caller redoes with intersectTriangle() (it re-evaluates in double).
struct WatertightLanes {
  __m256 t, u, v, ok;
  uint32_t on_edge;
};

// The part of the test before the division: edge functions, their signs, det and the scaled
// distance. `candidate` marks lanes that pass every test that does not need t itself; only
// those can be hits, so a block without any skips the division (most blocks a ray visits).
struct WatertightPrep {
  __m256 u, v, w, det, t_scaled, candidate;
  uint32_t on_edge;
};

PENUMBRA_AVX2_TARGET inline WatertightPrep watertightPrep(const __m256 px[3], const __m256 py[3],
                                                          const __m256 pz[3], __m256 sz,
                                                          __m256 tmin, __m256 tmax) {
  WatertightPrep p;
  // Edge functions u (edge b-c), v (c-a), w (a-b).
  p.u = _mm256_sub_ps(_mm256_mul_ps(px[2], py[1]), _mm256_mul_ps(py[2], px[1]));
  p.v = _mm256_sub_ps(_mm256_mul_ps(px[0], py[2]), _mm256_mul_ps(py[0], px[2]));
  p.w = _mm256_sub_ps(_mm256_mul_ps(px[1], py[0]), _mm256_mul_ps(py[1], px[0]));
  const __m256 zero = _mm256_setzero_ps();
  p.on_edge = uint32_t(_mm256_movemask_ps(_mm256_or_ps(
      _mm256_or_ps(_mm256_cmp_ps(p.u, zero, _CMP_EQ_OQ), _mm256_cmp_ps(p.v, zero, _CMP_EQ_OQ)),
      _mm256_cmp_ps(p.w, zero, _CMP_EQ_OQ))));
  // Off the edges (the lanes that matter here: edge lanes are redone by the scalar test), u, v
  // and w are non-zero, and the point is inside exactly when their signs agree; then det = u +
  // v + w cannot be zero either. NaN lanes fail the range test below.
  const __m256i differ = _mm256_srai_epi32(
      _mm256_castps_si256(_mm256_or_ps(_mm256_xor_ps(p.u, p.v), _mm256_xor_ps(p.u, p.w))), 31);
  p.det = _mm256_add_ps(_mm256_add_ps(p.u, p.v), p.w);
  const __m256 az = _mm256_mul_ps(sz, pz[0]), bz = _mm256_mul_ps(sz, pz[1]);
  const __m256 cz = _mm256_mul_ps(sz, pz[2]);
  p.t_scaled = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(p.u, az), _mm256_mul_ps(p.v, bz)),
                             _mm256_mul_ps(p.w, cz));
  // tmin det <= t_scaled <= tmax det for det > 0, the reverse for det < 0: both as
  // tmin |det| <= t_scaled sign(det) <= tmax |det| (negation is exact, so this is the same test).
  const __m256 sign = _mm256_and_ps(p.det, _mm256_set1_ps(-0.0f));
  const __m256 abs_det = _mm256_xor_ps(p.det, sign);
  const __m256 ts = _mm256_xor_ps(p.t_scaled, sign);
  const __m256 in_range =
      _mm256_and_ps(_mm256_cmp_ps(ts, _mm256_mul_ps(tmin, abs_det), _CMP_GE_OQ),
                    _mm256_cmp_ps(ts, _mm256_mul_ps(tmax, abs_det), _CMP_LE_OQ));
  p.candidate = _mm256_andnot_ps(_mm256_castsi256_ps(differ), in_range);
  return p;
}

// The division and the final range test on t, u, v.
PENUMBRA_AVX2_TARGET inline WatertightLanes watertightFinish(const WatertightPrep& p, __m256 tmin,
                                                             __m256 tmax) {
  WatertightLanes out;
  out.on_edge = p.on_edge;
  const __m256 inv_det = _mm256_div_ps(_mm256_set1_ps(1.0f), p.det);
  out.t = _mm256_mul_ps(p.t_scaled, inv_det);
  out.u = _mm256_mul_ps(p.v, inv_det);
  out.v = _mm256_mul_ps(p.w, inv_det);
  const __m256 t_ok =
      _mm256_and_ps(_mm256_cmp_ps(out.t, tmin, _CMP_GE_OQ), _mm256_cmp_ps(out.t, tmax, _CMP_LE_OQ));
  out.ok = _mm256_and_ps(p.candidate, t_ok);
  return out;
}

PENUMBRA_AVX2_TARGET inline WatertightLanes watertightLanes(const __m256 px[3], const __m256 py[3],
                                                            const __m256 pz[3], __m256 sz,
                                                            __m256 tmin, __m256 tmax) {
  return watertightFinish(watertightPrep(px, py, pz, sz, tmin, tmax), tmin, tmax);
}
#endif

// A leaf's triangles as structures of arrays, 320 bytes: v[k][axis][lane] is vertex k of
// triangle `lane`. Unused lanes have id -1 and zero vertices.
struct alignas(64) TriangleBlock8 {
  float v[3][3][8];
  int32_t id[8];
};
static_assert(sizeof(TriangleBlock8) == 320);

// Lanes of a block where the scalar test decides: those on an edge (the AVX2 path) or all
// (the scalar path). Each is tested with intersectTriangle(), which re-evaluates in double.
inline uint32_t intersectBlockLanes(const WatertightRay& r, const TriangleBlock8& b, uint32_t redo,
                                    float tmin, float tmax, float* t_out, float* u_out,
                                    float* v_out) {
  uint32_t mask = 0;
  while (redo) {
    const int i = __builtin_ctz(redo);
    redo &= redo - 1;
    const glm::vec3 p0(b.v[0][0][i], b.v[0][1][i], b.v[0][2][i]);
    const glm::vec3 p1(b.v[1][0][i], b.v[1][1][i], b.v[1][2][i]);
    const glm::vec3 p2(b.v[2][0][i], b.v[2][1][i], b.v[2][2][i]);
    if (intersectTriangle(r, p0, p1, p2, tmin, tmax, t_out[i], u_out[i], v_out[i])) {
      mask |= 1u << i;
    }
  }
  return mask;
}

// The watertight test (Woop et al. 2013, as in kernels/ray_triangle.h) of one ray against the
// `count` triangles of a block, eight lanes at once. Returns a mask of lanes hit within [tmin,
// tmax] and their t, u, v. Lanes where an edge function is exactly zero are redone with the
// scalar test, which re-evaluates them in double precision.
#if PENUMBRA_HAVE_AVX2_KERNELS
PENUMBRA_AVX2_TARGET inline uint32_t intersectBlockAvx2(const WatertightRay& r,
                                                        const TriangleBlock8& b, uint32_t count,
                                                        float tmin, float tmax, float* t_out,
                                                        float* u_out, float* v_out) {
  const uint32_t valid = (1u << count) - 1u;
  const __m256 ox = _mm256_set1_ps(r.okx), oy = _mm256_set1_ps(r.oky);
  const __m256 oz = _mm256_set1_ps(r.okz);
  const __m256 sx = _mm256_set1_ps(r.sx), sy = _mm256_set1_ps(r.sy), sz = _mm256_set1_ps(r.sz);
  __m256 px[3], py[3], pz[3];
  for (int k = 0; k < 3; ++k) {
    // Vertex relative to the origin, sheared into the ray's frame.
    const __m256 rx = _mm256_sub_ps(_mm256_load_ps(b.v[k][r.kx]), ox);
    const __m256 ry = _mm256_sub_ps(_mm256_load_ps(b.v[k][r.ky]), oy);
    const __m256 rz = _mm256_sub_ps(_mm256_load_ps(b.v[k][r.kz]), oz);
    px[k] = _mm256_sub_ps(rx, _mm256_mul_ps(sx, rz));
    py[k] = _mm256_sub_ps(ry, _mm256_mul_ps(sy, rz));
    pz[k] = rz;
  }
  const __m256 vtmin = _mm256_set1_ps(tmin), vtmax = _mm256_set1_ps(tmax);
  const WatertightPrep prep = watertightPrep(px, py, pz, sz, vtmin, vtmax);
  const uint32_t on_edge = prep.on_edge & valid;
  if ((uint32_t(_mm256_movemask_ps(prep.candidate)) & valid & ~on_edge) == 0) {
    return on_edge ? intersectBlockLanes(r, b, on_edge, tmin, tmax, t_out, u_out, v_out) : 0u;
  }
  const WatertightLanes lanes = watertightFinish(prep, vtmin, vtmax);
  const uint32_t mask = uint32_t(_mm256_movemask_ps(lanes.ok)) & valid & ~on_edge;
  _mm256_storeu_ps(t_out, lanes.t);
  _mm256_storeu_ps(u_out, lanes.u);
  _mm256_storeu_ps(v_out, lanes.v);
  return mask | intersectBlockLanes(r, b, on_edge, tmin, tmax, t_out, u_out, v_out);
}
#endif

// The same answers lane by lane, for CPUs without AVX2.
inline uint32_t intersectBlockScalar(const WatertightRay& r, const TriangleBlock8& b,
                                     uint32_t count, float tmin, float tmax, float* t_out,
                                     float* u_out, float* v_out) {
  return intersectBlockLanes(r, b, (1u << count) - 1u, tmin, tmax, t_out, u_out, v_out);
}

}  // namespace penumbra
