#include "penumbra/raytrace/ray_queries.h"

#include <fmt/format.h>

namespace penumbra {

Expected<std::unique_ptr<OwnedRayQueries>> OwnedRayQueries::make(const std::string& back_end,
                                                                 const SceneGeometry& geometry) {
  auto out = std::unique_ptr<OwnedRayQueries>(new OwnedRayQueries());
  out->back_end_ = back_end;
  if (back_end == "hybrid" && geometry.engine.hitFilter()) {
    return inputError("", "--device",
                      "the scene has cut-outs (alpha-masked or partly covering materials), which "
                      "the hybrid back end does not test: use --device cpu or gpu");
  }
  if (back_end == "cpu") {
    out->queries_ = std::make_unique<CpuRayQueries>(geometry.engine);
  } else if (back_end == "gpu") {
    // The GPU kernel tests the cut-outs the CPU engine's filter does (raytrace/gpu_cutouts.h).
    Expected<GlRayEngine> e =
        GlRayEngine::build(geometry.positions, geometry.triangles, {},
                           geometry.engine.hitFilter() ? geometry.textures.get() : nullptr);
    if (!e) return e.error();
    out->gl_.emplace(std::move(*e));
    out->queries_ = std::make_unique<GpuRayQueries>(*out->gl_);
  } else if (back_end == "hybrid") {
    Expected<HybridRayEngine> e = HybridRayEngine::build(geometry.positions, geometry.triangles);
    if (!e) return e.error();
    out->hybrid_.emplace(std::move(*e));
    out->queries_ = std::make_unique<HybridRayQueries>(*out->hybrid_);
  } else {
    return inputError("", "--device", fmt::format("unknown back end '{}'", back_end));
  }
  return out;
}

}  // namespace penumbra
