// The Ray Engine (Carr, Hall, Hart 2002) as a service: batches of rays in, closest hits or
// occlusion answers out, in input order. This is the CPU back end: the canonical binned-SAH
// BVH (accel/bvh.h) collapsed to 8-wide nodes with quantised child boxes (accel/wide_bvh.h)
// that one ray tests with AVX2, traversed in parallel over the batch with oneTBB, and the
// watertight ray-triangle test (kernels/ray_triangle.h) in the leaves.
#pragma once

#include "penumbra/accel/bvh.h"
#include "penumbra/accel/wide_bvh.h"
#include "penumbra/core/large_pages.h"
#include "penumbra/kernels/ray.h"
#include "penumbra/raytrace/cpu_simd.h"

#include <glm/vec3.hpp>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace penumbra {

// Triangles rays may pass through (cut-outs, scene/material.h AlphaMode): the engine asks the
// filter at every hit on a flagged triangle whether it stops the ray, and goes on past it when
// not, for closest hits and occlusion alike. An engine without a filter runs the kernels without
// the test.
class HitFilter {
 public:
  virtual ~HitFilter() = default;
  // Whether triangle `triangle` needs asking.
  virtual bool filtered(uint32_t triangle) const = 0;
  // Whether `ray`'s hit on `triangle` at barycentrics (u, v) stops it. The answer must depend on
  // nothing but the arguments, so that every query of the same ray agrees.
  virtual bool stops(uint32_t triangle, float u, float v, const Ray& ray) const = 0;
};

// The instruction sets the CPU back end has kernels for.
enum class CpuIsa { kScalar, kAvx2, kAvx512 };

class RayEngine {
 public:
  RayEngine() = default;

  // Builds the acceleration structure over `triangles` (indices into `positions`); the
  // triangle index reported in hits is the position in `triangles`.
  static RayEngine build(std::span<const glm::vec3> positions,
                         std::span<const glm::uvec3> triangles,
                         const BvhBuildOptions& options = cpuBuildOptions());

  // The build settings tuned for this back end (docs/performance.md): leaves of up to eight
  // triangles, priced by the SAH as one 8-wide block test, twice a node visit.
  static BvhBuildOptions cpuBuildOptions() {
    BvhBuildOptions o;
    o.max_leaf_size = 8;
    o.leaf_block = 8;
    o.traversal_cost = 1.0f;
    o.intersection_cost = 2.0f;
    return o;
  }

  // Sets the cut-out filter (none: null), or removes it.
  void setHitFilter(std::shared_ptr<const HitFilter> filter);
  const HitFilter* hitFilter() const { return filter_.get(); }

  // Single-ray conveniences.
  Hit intersect(const Ray& ray) const;
  bool occluded(const Ray& ray) const;

  // Batches, traced in parallel; results in input order. `hits` / `occluded` are resized
  // (reuse them across calls: a new 1M-ray hit batch is 16 MiB to allocate and touch). Batches
  // of 65,536 rays or more that do not come in coherent runs and mostly start inside the scene
  // are traced in coherentRayOrder (raytrace/ray_order.h); the answers are the same in any order.
  void intersect(const RayBatch& rays, HitBatch& hits) const;
  void occluded(const RayBatch& rays, std::vector<uint8_t>& occluded) const;
  // The same as intersect(rays, hits) on the calling thread (packets of coherent rays included),
  // for callers that run their own parallel loops over small batches.
  void intersectSerial(const RayBatch& rays, HitBatch& hits) const;
  // Whether intersect() traces `rays` in coherentRayOrder rather than input order.
  bool reorders(const RayBatch& rays) const;

  size_t triangleCount() const { return bvh_.refs.size(); }
  const Bvh& bvh() const { return bvh_; }
  size_t wideNodeCount() const { return std::max(nodes_.size(), float_nodes_.size()); }
  // The wide tree the CPU traverses (single rays and packets), in the layout of the kernels in
  // use: float child boxes for AVX-512 (floatNodes), boxes quantised to bytes for AVX2 and the
  // scalar loops (quantisedNodes); the other is made only when useIsa asks for it. Its root
  // reference follows
  // Bvh8Node::child's coding (a leaf for a tree of one leaf).
  const LargeVector<Bvh8Node>& floatNodes() const { return float_nodes_; }
  const LargeVector<Bvh8QNode>& quantisedNodes() const { return nodes_; }
  int32_t wideRoot() const { return root_; }

  // The kernels in use, chosen at run time by the CPU: AVX-512 (the fused slab test on float
  // boxes), else AVX2 (8-wide boxes and triangles, packets of 8 rays), else portable scalar
  // loops; all give identical answers. useIsa() asks for one (only what the CPU has), for tests
  // and comparisons; it makes the node layout that instruction set reads.
  CpuIsa isa() const { return isa_; }
  void useIsa(CpuIsa isa);
  const LargeVector<TriangleBlock8>& blocks() const { return blocks_; }
  // The leaf block holding the triangles of canonical leaf `node` (an element of bvh().nodes).
  uint32_t blockOfLeaf(const BvhNode& node) const {
    return block_of_node_[size_t(&node - bvh_.nodes.data())];
  }
  // Everything the engine holds: the wide nodes and leaf blocks it traverses, and the
  // canonical tree with its triangle references (the hybrid back end and the GPU layout use
  // them).
  size_t memoryBytes() const {
    return nodes_.size() * sizeof(Bvh8QNode) + float_nodes_.size() * sizeof(Bvh8Node) +
           blocks_.size() * sizeof(TriangleBlock8) + bvh_.memoryBytes() +
           block_of_node_.size() * sizeof(uint32_t);
  }
  Bounds3 bounds() const;
  // Starts fetching the node or leaf block `ref` (Bvh8Node::child's coding) into the cache, for
  // the kernels of `kIsa` (which node layout they read is known where they are compiled).
  template <CpuIsa kIsa>
  [[gnu::always_inline]] void prefetchRef(int32_t ref) const {
    const char* p;
    int lines;
    if (bvh8IsLeaf(ref)) {
      if (ref == Bvh8Node::kEmpty) return;
      p = reinterpret_cast<const char*>(&blocks_[bvh8LeafIndex(ref)]);
      lines = sizeof(TriangleBlock8) / 64;
    } else if constexpr (kIsa == CpuIsa::kAvx512) {
      p = reinterpret_cast<const char*>(&float_nodes_[size_t(ref)]);
      lines = sizeof(Bvh8Node) / 64;
    } else {
      p = reinterpret_cast<const char*>(&nodes_[size_t(ref)]);
      lines = sizeof(Bvh8QNode) / 64;
    }
    for (int i = 0; i < lines; ++i) __builtin_prefetch(p + 64 * i, 0, 3);
  }
  // The same for the kernels in use.
  [[gnu::always_inline]] void prefetchChild(int32_t ref) const {
    if (isa_ == CpuIsa::kAvx512) {
      prefetchRef<CpuIsa::kAvx512>(ref);
    } else {
      prefetchRef<CpuIsa::kAvx2>(ref);
    }
  }

 private:
  template <bool kAnyHit>
  bool traverse(const Ray& ray, Hit& hit) const;
  void intersectRange(const RayBatch& rays, size_t begin, size_t end, HitBatch& hits) const;
  template <bool kAnyHit, bool kFilter>
  bool traverseAvx512(const Ray& ray, Hit& hit) const;
  template <bool kAnyHit, bool kFilter>
  bool traverseAvx2(const Ray& ray, Hit& hit) const;
  template <bool kAnyHit, bool kFilter>
  bool traverseScalar(const Ray& ray, Hit& hit) const;
  template <bool kAnyHit, CpuIsa kIsa, bool kFilter>
  bool traverseBody(const Ray& ray, Hit& hit) const;
  // The node the instruction set's kernels read (float boxes for AVX-512, else quantised).
  template <CpuIsa kIsa>
  const auto& nodeAt(int32_t ref) const {
    if constexpr (kIsa == CpuIsa::kAvx512) {
      return float_nodes_[size_t(ref)];
    } else {
      return nodes_[size_t(ref)];
    }
  }
  // The hits of `mask` on the block that the filter lets stop the ray.
  uint32_t filterHits(const TriangleBlock8& block, uint32_t mask, const float* u, const float* v,
                      const Ray& ray) const;

  Bvh bvh_;  // canonical binary tree (other layouts)
  // The wide nodes in the layout the kernels in use read (the other empty); [0] is the root.
  LargeVector<Bvh8QNode> nodes_;       // AVX2 and scalar
  LargeVector<Bvh8Node> float_nodes_;  // AVX-512
  int32_t root_ = Bvh8Node::kEmpty;    // an inner node or a leaf (Bvh8Node::child's coding)
  CpuIsa isa_ = CpuIsa::kScalar;
  LargeVector<TriangleBlock8> blocks_;   // one per leaf, vertices copied in
  std::vector<uint32_t> block_of_node_;  // block index by canonical node (leaves only)
  std::shared_ptr<const HitFilter> filter_;
  std::vector<uint64_t> filtered_bits_;  // per triangle: filter_->filtered()
};

}  // namespace penumbra
