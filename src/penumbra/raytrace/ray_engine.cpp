#include "penumbra/raytrace/ray_engine.h"

#include "penumbra/core/parallel.h"
#include "penumbra/kernels/ray_triangle.h"

#include <algorithm>
#if defined(__AVX2__)
#include <immintrin.h>
#endif
#include <cmath>
#include <limits>

namespace penumbra {

RayEngine RayEngine::build(std::span<const glm::vec3> positions,
                           std::span<const glm::uvec3> triangles, const BvhBuildOptions& options) {
  RayEngine engine;
  engine.bvh_ = buildBvh(positions, triangles, options);
  engine.bvh8_ = collapseToBvh8(engine.bvh_);
  engine.triangles_.resize(triangles.size());
  parallelRange(triangles.size(), 4096, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const glm::uvec3 t = triangles[engine.bvh_.refs[i]];
      engine.triangles_[i] = {positions[t.x], positions[t.y], positions[t.z]};
    }
  });
  return engine;
}

Bounds3 RayEngine::bounds() const {
  if (bvh_.nodes.empty()) return Bounds3();
  return Bounds3{bvh_.nodes[0].lo, bvh_.nodes[0].hi};
}

namespace {

// 1 / d with zero components replaced by +-1e-30, so slab distances stay finite (no 0 * inf NaN).
// A tiny component only makes a box test more conservative, never cull a box the ray enters.
inline float safeReciprocal(float d) {
  return 1.0f / (std::fabs(d) < 1e-30f ? std::copysign(1e-30f, d) : d);
}

// Rounding margin for the far slab distance, 1 + 2 gamma(3), so rounding never culls a box the
// ray touches (Ize, "Robust BVH Ray Traversal", JCGT 2(2), 2013).
constexpr float kFarScale = 1.0000004f;

struct StackEntry {
  int32_t ref;
  float t_near;
};

// Stack capacity: each level of the tree pushes at most seven siblings.
constexpr int kStackSize = 7 * kMaxBvhDepth + 1;

// Slab tests of one ray against the eight child boxes of a node: bit i of the result is set
// when child i is entered within [tmin, tmax]; t_near receives the entry distances.
struct BoxTester {
  glm::vec3 org, inv;
  bool neg_x, neg_y, neg_z;

  BoxTester(const glm::vec3& o, const glm::vec3& d)
      : org(o),
        inv(safeReciprocal(d.x), safeReciprocal(d.y), safeReciprocal(d.z)),
        neg_x(inv.x < 0.0f),
        neg_y(inv.y < 0.0f),
        neg_z(inv.z < 0.0f) {}

  uint32_t test(const Bvh8Node& n, float tmin, float tmax, float* t_near) const {
    // Near and far planes per axis follow the direction's sign, so no min/max is needed and
    // an empty slot's inverted box (lo = +inf, hi = -inf) always fails.
    const float* nx = neg_x ? n.hi_x : n.lo_x;
    const float* fx = neg_x ? n.lo_x : n.hi_x;
    const float* ny = neg_y ? n.hi_y : n.lo_y;
    const float* fy = neg_y ? n.lo_y : n.hi_y;
    const float* nz = neg_z ? n.hi_z : n.lo_z;
    const float* fz = neg_z ? n.lo_z : n.hi_z;
#if defined(__AVX2__)
    const __m256 ox = _mm256_set1_ps(org.x), oy = _mm256_set1_ps(org.y),
                 oz = _mm256_set1_ps(org.z);
    const __m256 ix = _mm256_set1_ps(inv.x), iy = _mm256_set1_ps(inv.y),
                 iz = _mm256_set1_ps(inv.z);
    const __m256 tnx = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(nx), ox), ix);
    const __m256 tny = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(ny), oy), iy);
    const __m256 tnz = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(nz), oz), iz);
    const __m256 tfx = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(fx), ox), ix);
    const __m256 tfy = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(fy), oy), iy);
    const __m256 tfz = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(fz), oz), iz);
    const __m256 tn = _mm256_max_ps(_mm256_max_ps(tnx, tny), _mm256_max_ps(tnz, _mm256_set1_ps(tmin)));
    const __m256 tf = _mm256_mul_ps(
        _mm256_min_ps(_mm256_min_ps(tfx, tfy), _mm256_min_ps(tfz, _mm256_set1_ps(tmax))),
        _mm256_set1_ps(kFarScale));
    _mm256_storeu_ps(t_near, tn);
    return uint32_t(_mm256_movemask_ps(_mm256_cmp_ps(tn, tf, _CMP_LE_OQ)));
#else
    uint32_t mask = 0;
    for (int i = 0; i < 8; ++i) {
      const float tn = std::max(std::max((nx[i] - org.x) * inv.x, (ny[i] - org.y) * inv.y),
                                std::max((nz[i] - org.z) * inv.z, tmin));
      const float tf = std::min(std::min((fx[i] - org.x) * inv.x, (fy[i] - org.y) * inv.y),
                                std::min((fz[i] - org.z) * inv.z, tmax)) *
                       kFarScale;
      t_near[i] = tn;
      mask |= uint32_t(tn <= tf) << i;
    }
    return mask;
#endif
  }
};

}  // namespace

template <bool kAnyHit>
bool RayEngine::traverse(const Ray& ray, Hit& hit) const {
  if (bvh8_.root == Bvh8Node::kEmpty || !(ray.tmin <= ray.tmax)) return false;
  const WatertightRay wr = makeWatertightRay(ray.origin, ray.dir);
  const BoxTester boxes(ray.origin, ray.dir);
  float tmax = ray.tmax;
  bool found = false;

  StackEntry stack[kStackSize];
  int sp = 0;
  stack[sp++] = {bvh8_.root, ray.tmin};
  alignas(32) float t_near[8];
  while (sp > 0) {
    const StackEntry top = stack[--sp];
    if (top.t_near > tmax) continue;
    int32_t ref = top.ref;
    for (;;) {
      if (bvh8IsLeaf(ref)) {
        const uint32_t first = bvh8LeafFirst(ref), end = first + bvh8LeafCount(ref);
        for (uint32_t i = first; i < end; ++i) {
          const LeafTriangle& tri = triangles_[i];
          float t, u, v;
          if (intersectTriangle(wr, tri.p0, tri.p1, tri.p2, ray.tmin, tmax, t, u, v)) {
            const int32_t index = int32_t(bvh_.refs[i]);
            // Exact ties go to the lower triangle index, so the answer does not depend on the
            // tree's shape.
            if (t < tmax || !found || index < hit.triangle) {
              found = true;
              tmax = t;
              hit = Hit{index, t, u, v};
              if constexpr (kAnyHit) return true;
            }
          }
        }
        break;
      }
      const Bvh8Node& node = bvh8_.nodes[size_t(ref)];
      uint32_t mask = boxes.test(node, ray.tmin, tmax, t_near);
      if (mask == 0) break;
      int first = __builtin_ctz(mask);
      mask &= mask - 1;
      if (mask == 0) {
        ref = node.child[first];  // one child entered: descend without the stack
        continue;
      }
      // Several: sort by entry distance, farthest first (insertion sort, at most eight), push
      // all but the nearest and continue with it.
      StackEntry hits[8];
      int n = 0;
      hits[n++] = {node.child[first], t_near[first]};
      while (mask) {
        const int i = __builtin_ctz(mask);
        mask &= mask - 1;
        const StackEntry e{node.child[i], t_near[i]};
        int j = n++;
        while (j > 0 && hits[j - 1].t_near < e.t_near) {
          hits[j] = hits[j - 1];
          --j;
        }
        hits[j] = e;
      }
      for (int k = 0; k < n - 1; ++k) stack[sp++] = hits[k];
      ref = hits[n - 1].ref;
    }
  }
  return found;
}

Hit RayEngine::intersect(const Ray& ray) const {
  Hit hit;
  if (!traverse<false>(ray, hit)) hit = Hit{};
  return hit;
}

bool RayEngine::occluded(const Ray& ray) const {
  Hit hit;
  return traverse<true>(ray, hit);
}

void RayEngine::intersect(const RayBatch& rays, HitBatch& hits) const {
  hits.resize(rays.size());
  parallelRange(rays.size(), 256, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) hits.set(i, intersect(rays.get(i)));
  });
}

void RayEngine::occluded(const RayBatch& rays, std::vector<uint8_t>& occluded_out) const {
  occluded_out.resize(rays.size());
  parallelRange(rays.size(), 256, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) occluded_out[i] = occluded(rays.get(i)) ? 1 : 0;
  });
}

}  // namespace penumbra
