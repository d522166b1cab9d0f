// The CPU/GPU work split of the Ray Engine (Carr, Hall, Hart 2002, sec. 6.2, "Avoiding forced
// coherence"): subtrees of the BVH holding between T_min and T_max triangles are "GPU cells".
// Rays traverse the tree on the CPU; a ray entering a GPU cell is not taken further there but
// placed in that cell's ray cache, and a cache that reaches R_min rays is sent, with the cell's
// triangles, to the GPU kernel (GlRasterKernel, sec. 3.3-4.3) while the CPU goes on with other
// rays; results come back through fenced asynchronous readback. Everything else, and caches
// left short of R_min at the end (the paper's policy of forcing them to the CPU), is
// intersected on the CPU. A ray's answer is the nearest over all of these.
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
  uint32_t r_min = 256;   // rays a cell's cache collects before it goes to the GPU (a 16x16 tile)
};

struct HybridStats {
  size_t gpu_cells = 0;         // cells tagged in the tree
  size_t gpu_batches = 0;       // kernel submissions
  size_t gpu_ray_cells = 0;     // (ray, cell) pairs intersected on the GPU
  size_t forced_ray_cells = 0;  // pairs left in short caches and intersected on the CPU
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

 private:
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
  HybridOptions options_;
};

}  // namespace penumbra
