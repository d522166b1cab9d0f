// The Ray Engine's back ends behind the batched interface the wavefront path tracer uses
// (RayQueries, path_tracer.h): the CPU, the GPU kernel, and the CPU/GPU split.
#pragma once

#include "penumbra/raytrace/hybrid.h"
#include "penumbra/raytrace/path_tracer.h"
#include "penumbra/raytrace/ray_engine.h"
#include "penumbra/raytrace/ray_engine_gl.h"
#include "penumbra/raytrace/scene_geometry.h"

#include <memory>
#include <optional>
#include <string>

namespace penumbra {

class CpuRayQueries : public RayQueries {
 public:
  explicit CpuRayQueries(const RayEngine& engine) : engine_(engine) {}
  Status intersect(const RayBatch& rays, HitBatch& hits) override {
    engine_.intersect(rays, hits);
    return {};
  }
  Status occluded(const RayBatch& rays, std::vector<uint8_t>& occluded) override {
    engine_.occluded(rays, occluded);
    return {};
  }

 private:
  const RayEngine& engine_;
};

class GpuRayQueries : public RayQueries {
 public:
  explicit GpuRayQueries(const GlRayEngine& engine) : engine_(engine) {}
  Status intersect(const RayBatch& rays, HitBatch& hits) override {
    return engine_.intersect(rays, hits);
  }
  Status occluded(const RayBatch& rays, std::vector<uint8_t>& occluded) override {
    return engine_.occluded(rays, occluded);
  }

 private:
  const GlRayEngine& engine_;
};

// Occlusion through the split is a closest-hit query whose answer is only tested for a hit.
class HybridRayQueries : public RayQueries {
 public:
  explicit HybridRayQueries(const HybridRayEngine& engine) : engine_(engine) {}
  Status intersect(const RayBatch& rays, HitBatch& hits) override {
    HybridStats s;
    PENUMBRA_TRY(engine_.intersect(rays, hits, &s));
    accumulate(s);
    return {};
  }
  Status occluded(const RayBatch& rays, std::vector<uint8_t>& occluded) override {
    HybridStats s;
    PENUMBRA_TRY(engine_.intersect(rays, scratch_, &s));
    accumulate(s);
    occluded.resize(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) occluded[i] = scratch_.triangle[i] >= 0 ? 1 : 0;
    return {};
  }
  const HybridStats& stats() const { return stats_; }

 private:
  void accumulate(const HybridStats& s) {
    stats_.gpu_cells = s.gpu_cells;
    stats_.gpu_batches += s.gpu_batches;
    stats_.gpu_ray_cells += s.gpu_ray_cells;
    stats_.forced_ray_cells += s.forced_ray_cells;
    stats_.gpu_triangles += s.gpu_triangles;
    stats_.gpu_triangles_culled += s.gpu_triangles_culled;
  }
  const HybridRayEngine& engine_;
  HitBatch scratch_;
  HybridStats stats_;
};

}  // namespace penumbra

namespace penumbra {

// A back end of the Ray Engine with the engine it owns, for methods that trace in batches
// (whitted, photons): "cpu" (the CPU engine over `geometry`'s BVH), "gpu" (the compute kernel) or
// "hybrid" (the CPU/GPU split). The GPU ones need a current OpenGL 4.5 context.
class OwnedRayQueries : public RayQueries {
 public:
  static Expected<std::unique_ptr<OwnedRayQueries>> make(const std::string& back_end,
                                                         const SceneGeometry& geometry);
  Status intersect(const RayBatch& rays, HitBatch& hits) override {
    return queries_->intersect(rays, hits);
  }
  Status occluded(const RayBatch& rays, std::vector<uint8_t>& occluded) override {
    return queries_->occluded(rays, occluded);
  }
  const std::string& backEnd() const { return back_end_; }

 private:
  std::string back_end_;
  std::optional<GlRayEngine> gl_;
  std::optional<HybridRayEngine> hybrid_;
  std::unique_ptr<RayQueries> queries_;
};

}  // namespace penumbra
