#include "penumbra/raytrace/ray_engine.h"

#include "penumbra/core/parallel.h"
#include "penumbra/kernels/ray_triangle.h"
#include "penumbra/raytrace/cpu_avx512.h"
#include "penumbra/raytrace/cpu_packet.h"
#include "penumbra/raytrace/cpu_simd.h"
#include "penumbra/raytrace/ray_order.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace penumbra {

RayEngine RayEngine::build(std::span<const glm::vec3> positions,
                           std::span<const glm::uvec3> triangles, const BvhBuildOptions& options) {
  RayEngine engine;
  engine.bvh_ = buildBvh(positions, triangles, options);
  const Bvh8 wide = collapseToBvh8(engine.bvh_);
  engine.root_ = wide.root;
  engine.float_nodes_.assign(wide.nodes.begin(), wide.nodes.end());
  engine.useIsa(CpuIsa::kAvx512);
  const std::vector<Bvh8::Leaf>& leaves = wide.leaves;
  engine.blocks_.resize(leaves.size());
  // Canonical leaves by their first reference, then the block of each leaf node.
  std::vector<uint32_t> block_of_first(engine.bvh_.refs.size(), 0);
  for (size_t i = 0; i < leaves.size(); ++i) block_of_first[leaves[i].first] = uint32_t(i);
  engine.block_of_node_.assign(engine.bvh_.nodes.size(), 0);
  for (size_t n = 0; n < engine.bvh_.nodes.size(); ++n) {
    const BvhNode& node = engine.bvh_.nodes[n];
    if (node.isLeaf()) engine.block_of_node_[n] = block_of_first[node.index];
  }
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

#if PENUMBRA_HAVE_AVX2_KERNELS
// Orders the children a ray entered without a branch per child (incoherent rays mispredict
// most of those): the entry distances, each with its slot in the three low mantissa bits, go
// through Batcher's odd-even merge sort of eight keys (19 comparators in 6 layers; Knuth, TAOCP
// vol. 3, sec. 5.3.4), lanes not entered last. The entered children but the nearest are stored
// farthest first at `refs` / `ts` (whole vectors: the stack keeps eight spare slots), and the
// nearest is returned, found by a separate minimum so its fetch need not wait for the sort.
// The stored distances are the exact ones; the keys only order.
template <int kMaxLanes>
PENUMBRA_AVX2_TARGET inline __m256 sortLayer(__m256 v, __m256i partner) {
  const __m256 p = _mm256_permutevar8x32_ps(v, partner);
  return _mm256_blend_ps(_mm256_min_ps(v, p), _mm256_max_ps(v, p), kMaxLanes);
}

template <typename Node>
PENUMBRA_AVX2_TARGET inline int32_t pushChildrenAvx2(const Node& node, uint32_t mask,
                                                     const float* t_near, int32_t* refs,
                                                     float* ts) {
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256 tn = _mm256_load_ps(t_near);
  const __m256i bit = _mm256_sllv_epi32(_mm256_set1_epi32(1), lane);
  const __m256i entered =
      _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(int(mask)), bit), bit);
  const __m256i low = _mm256_set1_epi32(~7);
  __m256i key = _mm256_or_si256(_mm256_and_si256(_mm256_castps_si256(tn), low), lane);
  // Not entered: the largest finite float, same slot bits.
  key = _mm256_blendv_epi8(_mm256_or_si256(_mm256_set1_epi32(0x7f7ffff8), lane), key, entered);
  const __m256 k = _mm256_castsi256_ps(key);
  // The nearest: a horizontal minimum in three steps.
  __m256 m =
      _mm256_min_ps(k, _mm256_permutevar8x32_ps(k, _mm256_setr_epi32(1, 0, 3, 2, 5, 4, 7, 6)));
  m = _mm256_min_ps(m, _mm256_permutevar8x32_ps(m, _mm256_setr_epi32(2, 3, 0, 1, 6, 7, 4, 5)));
  m = _mm256_min_ps(m, _mm256_permutevar8x32_ps(m, _mm256_setr_epi32(4, 5, 6, 7, 0, 1, 2, 3)));
  const int nearest = _mm256_cvtsi256_si32(_mm256_castps_si256(m)) & 7;
  // The others, sorted ascending.
  __m256 s = sortLayer<0xAA>(k, _mm256_setr_epi32(1, 0, 3, 2, 5, 4, 7, 6));
  s = sortLayer<0xCC>(s, _mm256_setr_epi32(2, 3, 0, 1, 6, 7, 4, 5));
  s = sortLayer<0x44>(s, _mm256_setr_epi32(0, 2, 1, 3, 4, 6, 5, 7));
  s = sortLayer<0xF0>(s, _mm256_setr_epi32(4, 5, 6, 7, 0, 1, 2, 3));
  s = sortLayer<0x30>(s, _mm256_setr_epi32(0, 1, 4, 5, 2, 3, 6, 7));
  s = sortLayer<0x54>(s, _mm256_setr_epi32(0, 2, 1, 4, 3, 6, 5, 7));
  // Stack slot j takes sorted element count - 1 - j: the farthest lowest, the second nearest on
  // top.
  const int count = __builtin_popcount(mask);
  const __m256i sorted_slot = _mm256_and_si256(_mm256_castps_si256(s), _mm256_set1_epi32(7));
  const __m256i order =
      _mm256_and_si256(_mm256_sub_epi32(_mm256_set1_epi32(count - 1), lane), _mm256_set1_epi32(7));
  const __m256i slot = _mm256_permutevar8x32_epi32(sorted_slot, order);
  const __m256i child = _mm256_load_si256(reinterpret_cast<const __m256i*>(node.child));
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(refs), _mm256_permutevar8x32_epi32(child, slot));
  _mm256_storeu_ps(ts, _mm256_permutevar8x32_ps(tn, slot));
  return node.child[nearest];
}
#endif

namespace {

// The block's `count` triangles against the ray within [tmin, tmax]: bit i set for a hit of
// triangle i, with its t, u, v.
template <CpuIsa kIsa>
[[gnu::always_inline]] inline uint32_t intersectLeaf(const WatertightRay& wr,
                                                     const TriangleBlock8& block, uint32_t count,
                                                     float tmin, float tmax, float* t, float* u,
                                                     float* v) {
#if PENUMBRA_HAVE_AVX2_KERNELS
  if constexpr (kIsa != CpuIsa::kScalar) {
    return intersectBlockAvx2(wr, block, count, tmin, tmax, t, u, v);
  }
#endif
  return intersectBlockScalar(wr, block, count, tmin, tmax, t, u, v);
}

// The node's children against the ray within [tmin, tmax]: bit i set when child i is entered,
// at t_near[i].
template <CpuIsa kIsa, typename Tester>
[[gnu::always_inline]] inline uint32_t testChildren(const Tester& boxes, const auto& node,
                                                    float tmin, float tmax, float* t_near) {
#if PENUMBRA_HAVE_AVX2_KERNELS
  if constexpr (kIsa == CpuIsa::kAvx512) {
    return boxes.test(node, tmin, tmax, t_near);
  } else if constexpr (kIsa == CpuIsa::kAvx2) {
    return boxes.testAvx2(node, tmin, tmax, t_near);
  } else
#endif
  {
    return boxes.testScalar(node, tmin, tmax, t_near);
  }
}

// The box tester of each instruction set.
template <CpuIsa kIsa>
struct TesterOf {
  using type = BoxTester;
};
#if PENUMBRA_HAVE_AVX2_KERNELS
template <>
struct TesterOf<CpuIsa::kAvx512> {
  using type = BoxTesterFloat;
};
#endif

}  // namespace

void RayEngine::setHitFilter(std::shared_ptr<const HitFilter> filter) {
  filter_ = std::move(filter);
  filtered_bits_.clear();
  if (!filter_) return;
  const size_t n = triangleCount();
  filtered_bits_.assign((n + 63) / 64, 0);
  bool any = false;
  for (size_t t = 0; t < n; ++t) {
    if (filter_->filtered(uint32_t(t))) {
      filtered_bits_[t / 64] |= uint64_t(1) << (t % 64);
      any = true;
    }
  }
  // Nothing to ask: the unfiltered kernels.
  if (!any) {
    filter_.reset();
    filtered_bits_.clear();
  }
}

uint32_t RayEngine::filterHits(const TriangleBlock8& block, uint32_t mask, const float* u,
                               const float* v, const Ray& ray) const {
  for (uint32_t m = mask; m; m &= m - 1) {
    const int i = __builtin_ctz(m);
    const uint32_t tri = uint32_t(block.id[i]);
    if ((filtered_bits_[tri / 64] >> (tri % 64)) & 1) {
      if (!filter_->stops(tri, u[i], v[i], ray)) mask &= ~(1u << i);
    }
  }
  return mask;
}

template <bool kAnyHit, CpuIsa kIsa, bool kFilter>
[[gnu::always_inline]] inline bool RayEngine::traverseBody(const Ray& ray, Hit& hit) const {
  if (root_ == Bvh8Node::kEmpty || !(ray.tmin <= ray.tmax)) return false;
  const typename TesterOf<kIsa>::type boxes(ray.origin, ray.dir);
  // Built at the first leaf: most rays of a camera that frames a model never reach one.
  WatertightRay wr;
  bool have_wr = false;
  float tmax = ray.tmax;
  bool found = false;

  // References and entry distances; eight spare slots, as the vector paths store whole vectors.
  int32_t stack_ref[kStackSize + 8];
  float stack_t[kStackSize + 8];
  int sp = 0;
  stack_ref[0] = root_, stack_t[0] = ray.tmin, sp = 1;
  alignas(32) float t_near[8];
  while (sp > 0) {
    --sp;
    if (stack_t[sp] > tmax) continue;
    int32_t ref = stack_ref[sp];
    for (;;) {
      if (bvh8IsLeaf(ref)) {
        if (ref == Bvh8Node::kEmpty) break;
        const TriangleBlock8& block = blocks_[bvh8LeafIndex(ref)];
        if (!have_wr) {
          wr = makeWatertightRay(ray.origin, ray.dir);
          have_wr = true;
        }
        alignas(32) float t[8], u[8], v[8];
        uint32_t mask = intersectLeaf<kIsa>(wr, block, bvh8LeafCount(ref), ray.tmin, tmax, t, u, v);
        if constexpr (kFilter) {
          if (mask) mask = filterHits(block, mask, u, v, ray);
        }
        if constexpr (kAnyHit) {
          if (mask) return true;
        }
        while (mask) {
          const int i = __builtin_ctz(mask);
          mask &= mask - 1;
          // Exact ties go to the lower triangle index, so the answer does not depend on the
          // tree's shape or the order of the visit.
          if (t[i] < tmax || (t[i] == tmax && (!found || block.id[i] < hit.triangle))) {
            found = true;
            tmax = t[i];
            hit = Hit{block.id[i], t[i], u[i], v[i]};
          }
        }
        break;
      }
      const auto& node = nodeAt<kIsa>(ref);
      uint32_t mask = testChildren<kIsa>(boxes, node, ray.tmin, tmax, t_near);
      if (mask == 0) break;
      // Start fetching every child entered: their lines arrive while this node is sorted and
      // the nearest child visited.
      for (uint32_t m = mask; m; m &= m - 1) prefetchRef<kIsa>(node.child[__builtin_ctz(m)]);
      int first = __builtin_ctz(mask);
      mask &= mask - 1;
      if (mask == 0) {
        ref = node.child[first];  // one child entered: descend without the stack
        continue;
      }
      if constexpr (kAnyHit) {
        // Any hit ends the search: distance order saves nothing worth a sort.
        for (; mask; mask &= mask - 1) {
          const int i = __builtin_ctz(mask);
          stack_ref[sp] = node.child[i], stack_t[sp] = t_near[i], ++sp;
        }
        ref = node.child[first];
        continue;
      }
      const int second = __builtin_ctz(mask);
      mask &= mask - 1;
      if (mask == 0) {
        // Two (the most common case after one): push the farther, continue with the nearer.
        const bool first_near = t_near[first] <= t_near[second];
        const int near = first_near ? first : second, far = first_near ? second : first;
        stack_ref[sp] = node.child[far], stack_t[sp] = t_near[far], ++sp;
        ref = node.child[near];
        continue;
      }
      mask |= 1u << first | 1u << second;
#if PENUMBRA_HAVE_AVX2_KERNELS
      if constexpr (kIsa != CpuIsa::kScalar) {
        ref = pushChildrenAvx2(node, mask, t_near, stack_ref + sp, stack_t + sp);
        sp += __builtin_popcount(mask) - 1;
        continue;
      }
#endif
      // More: sort by entry distance, farthest first (insertion sort, at most eight), push
      // all but the nearest and continue with it.
      StackEntry sorted[8];
      int n = 0;
      while (mask) {
        const int i = __builtin_ctz(mask);
        mask &= mask - 1;
        const StackEntry e{node.child[i], t_near[i]};
        int j = n++;
        while (j > 0 && sorted[j - 1].t_near < e.t_near) {
          sorted[j] = sorted[j - 1];
          --j;
        }
        sorted[j] = e;
      }
      for (int k = 0; k < n - 1; ++k)
        stack_ref[sp] = sorted[k].ref, stack_t[sp] = sorted[k].t_near, ++sp;
      ref = sorted[n - 1].ref;
    }
  }
  return found;
}

// The instruction sets' traversals: the same body, compiled once for AVX-512, once for AVX2 and
// once for the build's target; which one runs is decided per engine at build time (useIsa).
#if PENUMBRA_HAVE_AVX2_KERNELS
template <bool kAnyHit, bool kFilter>
PENUMBRA_AVX512_TARGET bool RayEngine::traverseAvx512(const Ray& ray, Hit& hit) const {
  return traverseBody<kAnyHit, CpuIsa::kAvx512, kFilter>(ray, hit);
}

template <bool kAnyHit, bool kFilter>
PENUMBRA_AVX2_TARGET bool RayEngine::traverseAvx2(const Ray& ray, Hit& hit) const {
  return traverseBody<kAnyHit, CpuIsa::kAvx2, kFilter>(ray, hit);
}
#endif

template <bool kAnyHit, bool kFilter>
bool RayEngine::traverseScalar(const Ray& ray, Hit& hit) const {
  return traverseBody<kAnyHit, CpuIsa::kScalar, kFilter>(ray, hit);
}

template <bool kAnyHit>
bool RayEngine::traverse(const Ray& ray, Hit& hit) const {
  // Cut-outs take their own instantiation: opaque scenes keep the kernels without the test.
  if (filter_) [[unlikely]] {
#if PENUMBRA_HAVE_AVX2_KERNELS
    if (isa_ == CpuIsa::kAvx512) return traverseAvx512<kAnyHit, true>(ray, hit);
    if (isa_ == CpuIsa::kAvx2) return traverseAvx2<kAnyHit, true>(ray, hit);
#endif
    return traverseScalar<kAnyHit, true>(ray, hit);
  }
#if PENUMBRA_HAVE_AVX2_KERNELS
  if (isa_ == CpuIsa::kAvx512) return traverseAvx512<kAnyHit, false>(ray, hit);
  if (isa_ == CpuIsa::kAvx2) return traverseAvx2<kAnyHit, false>(ray, hit);
#endif
  return traverseScalar<kAnyHit, false>(ray, hit);
}

void RayEngine::useIsa(CpuIsa isa) {
  if (isa == CpuIsa::kAvx512 && !cpuHasAvx512()) isa = CpuIsa::kAvx2;
  if (isa == CpuIsa::kAvx2 && !cpuHasAvx2()) isa = CpuIsa::kScalar;
  isa_ = isa;
  if (isa == CpuIsa::kAvx512 || !nodes_.empty()) return;
  // The quantised layout, made from the float nodes (kept: the engine may be asked for AVX-512
  // again); on a CPU without AVX-512 they are only the source and go.
  nodes_.resize(float_nodes_.size());
  parallelRange(float_nodes_.size(), 1024, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) nodes_[i] = quantizeBvh8Node(float_nodes_[i]);
  });
  if (!cpuHasAvx512()) float_nodes_ = LargeVector<Bvh8Node>();
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
  // Packets have no cut-out test: with a filter every ray goes alone.
  const bool packets = isa_ != CpuIsa::kScalar && !filter_;
  for (size_t i = begin; i < end; i += kPacketSize) {
    const size_t group_end = std::min(end, i + kPacketSize);
    if (packets && group_end - i == kPacketSize && packetEligible(rays, i)) {
      tracePacket(*this, rays, i, hits);
      continue;
    }
    for (size_t k = i; k < group_end; ++k) hits.set(k, intersect(rays.get(k)));
  }
}

namespace {

// Large incoherent batches are traced in coherentRayOrder (raytrace/ray_order.h) when the
// scene's nodes and leaves outgrow the caches a core has to itself: below 65,536 rays or 8 MiB
// the sort does not pay (measured: a 1.1M-triangle scene's diffuse rays 23% faster including
// the sort, the bunny's (4 MiB) 0-7% slower; docs/performance.md). Nor does it for rays that
// start outside the scene, whose origins say nothing of where they go: the same scene's chords
// between points of its bounding sphere took 123-132 ms sorted against 91-93 ms in input order.
constexpr size_t kReorderRays = size_t(1) << 16;
constexpr size_t kReorderBytes = size_t(8) << 20;

// Starts fetching ray i's eight values (the arrays are far apart, and i jumps in sorted order).
inline void prefetchRay(const RayBatch& rays, size_t i) {
  for (const LargeVector<float>* v :
       {&rays.ox, &rays.oy, &rays.oz, &rays.tmin, &rays.dx, &rays.dy, &rays.dz, &rays.tmax}) {
    __builtin_prefetch(v->data() + i, 0, 1);
  }
}

// Calls trace(i) for every ray, in `order`, in parallel chunks.
template <typename Trace>
void traceInOrder(const RayBatch& rays, const LargeVector<uint32_t>& order, Trace&& trace) {
  constexpr size_t kAhead = 8;
  parallelRange(order.size(), 256, [&](size_t begin, size_t end) {
    for (size_t j = begin; j < end; ++j) {
      if (j + kAhead < end) prefetchRay(rays, order[j + kAhead]);
      trace(order[j]);
    }
  });
}

}  // namespace

bool RayEngine::reorders(const RayBatch& rays) const {
  return rays.size() >= kReorderRays && memoryBytes() >= kReorderBytes && !batchIsCoherent(rays) &&
         batchStartsInside(rays, bounds());
}

void RayEngine::intersect(const RayBatch& rays, HitBatch& hits) const {
  hits.resize(rays.size());
  if (reorders(rays)) {
    const LargeVector<uint32_t> order = coherentRayOrder(rays, bounds());
    traceInOrder(rays, order, [&](size_t i) { hits.set(i, intersect(rays.get(i))); });
    return;
  }
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
  if (reorders(rays)) {
    const LargeVector<uint32_t> order = coherentRayOrder(rays, bounds());
    traceInOrder(rays, order, [&](size_t i) { occluded_out[i] = occluded(rays.get(i)) ? 1 : 0; });
    return;
  }
  parallelRange(rays.size(), 256, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) occluded_out[i] = occluded(rays.get(i)) ? 1 : 0;
  });
}

}  // namespace penumbra
