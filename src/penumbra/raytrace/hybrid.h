// The CPU/GPU work split of the Ray Engine (Carr, Hall, Hart 2002, sec. 6.2, "Avoiding forced
// coherence"): subtrees of the BVH holding between T_min and T_max triangles are "GPU cells".
// Rays traverse the tree on the CPU; a ray entering a GPU cell is not taken further there but
// placed in that cell's ray cache, a 5-D ray tree (RayCache, sec. 5.3) with buckets of R_min
// rays. "When ... the entire ray cache becomes full" (it holds cache_rays rays) its fullest
// coherent bucket is sent, with the cell's triangles, to the GPU kernel (GlRasterKernel,
// sec. 3.3-4.3) while the CPU goes on with other rays; results come back through fenced
// asynchronous readback. "When the ray tracer needs a result" (the end of the batch) every cache
// is drained: full buckets go to the GPU, the remainder short of R_min is forced to the CPU (the
// paper's policy). Everything outside GPU cells is intersected on the CPU. A ray's answer is the
// nearest over all of these. The kernel's vertex stage culls the cell's triangles that no ray
// of the bucket can reach (sec. 5.3, kernels/bucket_cull.h), and the more coherent the bucket,
// the more it culls; with cache_rays == R_min a bucket is simply the first R_min rays to arrive.
//
// Needs a current OpenGL context (gpu/context.h) on the calling thread.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/raytrace/ray_engine.h"
#include "penumbra/raytrace/ray_engine_gl.h"

#include <span>
#include <vector>

namespace penumbra {

struct HybridOptions {
  uint32_t t_min = 64;    // a GPU cell represents at least this many triangles
  uint32_t t_max = 1024;  // and at most this many (the GPU kernel is all-pairs, O(R T))
  uint32_t r_min = 256;   // rays per GPU pass: the ray cache's bucket size (a 16x16 tile)
  // Capacity of each GPU cell's ray cache, in rays; 0 means 4 * r_min. A full cache sends its
  // fullest bucket to the GPU. Larger caches give the 5-D tree more rays to choose coherent
  // buckets from (tighter buckets, more culled triangles) at the cost of holding rays longer;
  // r_min sends rays in arrival order. Contract: 0 or >= r_min.
  uint32_t cache_rays = 0;
};

struct HybridStats {
  size_t gpu_cells = 0;         // cells tagged in the tree
  size_t gpu_batches = 0;       // kernel submissions, each of R_min rays
  size_t gpu_ray_cells = 0;     // (ray, cell) pairs intersected on the GPU
  size_t forced_ray_cells = 0;  // pairs left in short caches and intersected on the CPU
  // Triangles drawn by the GPU passes (a cell's triangles per pass), and how many of them the
  // vertex stage culled as out of the bucket's reach (sec. 5.3; counted with the C++ twin of
  // the shader's test, O(T) per pass, only when intersect() is given stats). Each triangle
  // stands for R_min ray-triangle tests.
  size_t gpu_triangles = 0;
  size_t gpu_triangles_culled = 0;
};

class HybridRayEngine {
 public:
  static Expected<HybridRayEngine> build(std::span<const glm::vec3> positions,
                                         std::span<const glm::uvec3> triangles,
                                         const HybridOptions& options = {});

  // Closest hits in input order: the CPU back end's answers, except that the GPU kernel's
  // t may differ in the last bits, which can swap true ties.
  Status intersect(const RayBatch& rays, HitBatch& hits, HybridStats* stats = nullptr) const;

  size_t cellCount() const { return cells_.size(); }
  const HybridOptions& options() const { return options_; }  // cache_rays resolved

 private:
  class Batch;  // one intersect() call's state (hybrid.cpp)
  struct Cell {
    uint32_t node;   // canonical BVH node at the cell's root
    uint32_t first;  // its triangles are slots [first, first + count) in leaf order
    uint32_t count;
  };
  // Single-ray traversal from `node`; GPU cells are not entered but reported to `cells` (when
  // non-null).
  void traverse(uint32_t node, const Ray& ray, Hit& hit, std::vector<uint32_t>* cells) const;

  RayEngine cpu_;
  GlRasterKernel gpu_;
  std::vector<int32_t> cell_of_node_;  // -1, or the cell rooted at this node
  std::vector<Cell> cells_;
  HybridOptions options_;  // cache_rays resolved (never 0)
};

}  // namespace penumbra
