#include "penumbra/raytrace/ray_engine.h"

#include "penumbra/core/parallel.h"
#include "penumbra/kernels/ray_triangle.h"
#include "penumbra/raytrace/cpu_packet.h"
#include "penumbra/raytrace/cpu_simd.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace penumbra {

RayEngine RayEngine::build(std::span<const glm::vec3> positions,
                           std::span<const glm::uvec3> triangles, const BvhBuildOptions& options) {
  RayEngine engine;
  engine.bvh_ = buildBvh(positions, triangles, options);
  engine.bvh8_ = collapseToBvh8(engine.bvh_);
  engine.useIsa(CpuIsa::kAvx2);
  const std::vector<Bvh8::Leaf>& leaves = engine.bvh8_.leaves;
  engine.blocks_.resize(leaves.size());
  engine.block_of_first_.assign(engine.bvh_.refs.size(), 0);
  for (size_t i = 0; i < leaves.size(); ++i) engine.block_of_first_[leaves[i].first] = uint32_t(i);
  parallelRange(leaves.size(), 1024, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      TriangleBlock8& block = engine.blocks_[i];
      block = TriangleBlock8{};
      for (uint32_t lane = 0; lane < 8; ++lane) {
        if (lane >= leaves[i].count) {
          block.id[lane] = -1;
          continue;
        }
        const uint32_t tri = engine.bvh_.refs[leaves[i].first + lane];
        const glm::uvec3 t = triangles[tri];
        const glm::vec3 p[3] = {positions[t.x], positions[t.y], positions[t.z]};
        for (int k = 0; k < 3; ++k) {
          for (int axis = 0; axis < 3; ++axis) block.v[k][axis][lane] = p[k][axis];
        }
        block.id[lane] = int32_t(tri);
      }
    }
  });
  return engine;
}

Bounds3 RayEngine::bounds() const {
  if (bvh_.nodes.empty()) return Bounds3();
  return Bounds3{bvh_.nodes[0].lo, bvh_.nodes[0].hi};
}

namespace {

struct StackEntry {
  int32_t ref;
  float t_near;
};

// Stack capacity: each level of the tree pushes at most seven siblings.
constexpr int kStackSize = 7 * kMaxBvhDepth + 1;

}  // namespace

[[gnu::always_inline]] inline void RayEngine::prefetchChild(int32_t ref) const {
  const char* p;
  int lines;
  if (bvh8IsLeaf(ref)) {
    if (ref == Bvh8Node::kEmpty) return;
    p = reinterpret_cast<const char*>(&blocks_[bvh8LeafIndex(ref)]);
    lines = sizeof(TriangleBlock8) / 64;
  } else {
    p = reinterpret_cast<const char*>(&bvh8_.nodes[size_t(ref)]);
    lines = sizeof(Bvh8Node) / 64;
  }
  for (int i = 0; i < lines; ++i) __builtin_prefetch(p + 64 * i, 0, 3);
}

template <bool kAnyHit, bool kAvx2>
[[gnu::always_inline]] inline bool RayEngine::traverseBody(const Ray& ray, Hit& hit) const {
  if (bvh8_.root == Bvh8Node::kEmpty || !(ray.tmin <= ray.tmax)) return false;
  const BoxTester boxes(ray.origin, ray.dir);
  // Built at the first leaf: most rays of a camera that frames a model never reach one.
  WatertightRay wr;
  bool have_wr = false;
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
        if (ref == Bvh8Node::kEmpty) break;
        const TriangleBlock8& block = blocks_[bvh8LeafIndex(ref)];
        if (!have_wr) {
          wr = makeWatertightRay(ray.origin, ray.dir);
          have_wr = true;
        }
        alignas(32) float t[8], u[8], v[8];
        uint32_t mask;
#if PENUMBRA_HAVE_AVX2_KERNELS
        if constexpr (kAvx2) {
          mask = intersectBlockAvx2(wr, block, bvh8LeafCount(ref), ray.tmin, tmax, t, u, v);
        } else
#endif
        {
          mask = intersectBlockScalar(wr, block, bvh8LeafCount(ref), ray.tmin, tmax, t, u, v);
        }
        if constexpr (kAnyHit) {
          if (mask) return true;
        }
        while (mask) {
          const int i = __builtin_ctz(mask);
          mask &= mask - 1;
          // Exact ties go to the lower triangle index, so the answer does not depend on the
          // tree's shape.
          if (t[i] < tmax || (t[i] == tmax && (!found || block.id[i] < hit.triangle))) {
            found = true;
            tmax = t[i];
            hit = Hit{block.id[i], t[i], u[i], v[i]};
          }
        }
        break;
      }
      const Bvh8Node& node = bvh8_.nodes[size_t(ref)];
      uint32_t mask;
#if PENUMBRA_HAVE_AVX2_KERNELS
      if constexpr (kAvx2) {
        mask = boxes.testAvx2(node, ray.tmin, tmax, t_near);
      } else
#endif
      {
        mask = boxes.testScalar(node, ray.tmin, tmax, t_near);
      }
      if (mask == 0) break;
      // Start fetching every child entered: their lines arrive while this node is sorted and
      // the nearest child visited.
      for (uint32_t m = mask; m; m &= m - 1) prefetchChild(node.child[__builtin_ctz(m)]);
      int first = __builtin_ctz(mask);
      mask &= mask - 1;
      if (mask == 0) {
        ref = node.child[first];  // one child entered: descend without the stack
        continue;
      }
      const int second = __builtin_ctz(mask);
      mask &= mask - 1;
      if (mask == 0) {
        // Two (the most common case after one): push the farther, continue with the nearer.
        const bool first_near = t_near[first] <= t_near[second];
        const int near = first_near ? first : second, far = first_near ? second : first;
        stack[sp++] = {node.child[far], t_near[far]};
        ref = node.child[near];
        continue;
      }
      // More: sort by entry distance, farthest first (insertion sort, at most eight), push
      // all but the nearest and continue with it.
      StackEntry hits[8];
      int n = 0;
      hits[n++] = {node.child[first], t_near[first]};
      mask |= 1u << second;
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

// The two instruction sets' traversals: the same body, compiled once for AVX2 and once for the
// build's target; which one runs is decided per engine at build time (cpuHasAvx2).
#if PENUMBRA_HAVE_AVX2_KERNELS
template <bool kAnyHit>
PENUMBRA_AVX2_TARGET bool RayEngine::traverseAvx2(const Ray& ray, Hit& hit) const {
  return traverseBody<kAnyHit, true>(ray, hit);
}
#endif

template <bool kAnyHit>
bool RayEngine::traverseScalar(const Ray& ray, Hit& hit) const {
  return traverseBody<kAnyHit, false>(ray, hit);
}

template <bool kAnyHit>
bool RayEngine::traverse(const Ray& ray, Hit& hit) const {
#if PENUMBRA_HAVE_AVX2_KERNELS
  if (isa_ == CpuIsa::kAvx2) return traverseAvx2<kAnyHit>(ray, hit);
#endif
  return traverseScalar<kAnyHit>(ray, hit);
}

void RayEngine::useIsa(CpuIsa isa) {
  isa_ = isa == CpuIsa::kAvx2 && cpuHasAvx2() ? CpuIsa::kAvx2 : CpuIsa::kScalar;
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

// Within [begin, end), each aligned group of eight rays that go the same way travels as a packet
// (cpu_packet.h), the others one by one. Groups are tested once, not at every ray: incoherent
// rays then pay one failed test per eight rays.
void RayEngine::intersectRange(const RayBatch& rays, size_t begin, size_t end,
                               HitBatch& hits) const {
  const bool packets = isa_ == CpuIsa::kAvx2;
  for (size_t i = begin; i < end; i += kPacketSize) {
    const size_t group_end = std::min(end, i + kPacketSize);
    if (packets && group_end - i == kPacketSize && packetEligible(rays, i)) {
      tracePacket(*this, rays, i, hits);
      continue;
    }
    for (size_t k = i; k < group_end; ++k) hits.set(k, intersect(rays.get(k)));
  }
}

void RayEngine::intersect(const RayBatch& rays, HitBatch& hits) const {
  hits.resize(rays.size());
  // Chunks of 256 rays (aligned, so packets never straddle two chunks).
  parallelRange((rays.size() + 255) / 256, 1, [&](size_t chunk_begin, size_t chunk_end) {
    intersectRange(rays, chunk_begin * 256, std::min(rays.size(), chunk_end * 256), hits);
  });
}

void RayEngine::intersectSerial(const RayBatch& rays, HitBatch& hits) const {
  hits.resize(rays.size());
  intersectRange(rays, 0, rays.size(), hits);
}

void RayEngine::occluded(const RayBatch& rays, std::vector<uint8_t>& occluded_out) const {
  occluded_out.resize(rays.size());
  parallelRange(rays.size(), 256, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) occluded_out[i] = occluded(rays.get(i)) ? 1 : 0;
  });
}

}  // namespace penumbra
