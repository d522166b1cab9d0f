// The Ray Engine's cut-out test (ray_engine.h HitFilter) over a scene's materials
// (scene/surface_textures.h): a hit on a masked triangle stops the ray where the material's
// alpha reaches its cutoff; on a partly covering one (kBlend) with probability alpha, decided by
// a hash of the ray and the triangle (stochastic transparency, Enderton et al. 2010), so every
// query of the same ray gets the same answer and different rays independent ones.
#pragma once

#include "penumbra/raytrace/ray_engine.h"
#include "penumbra/scene/surface_textures.h"

#include <memory>

namespace penumbra {

class CutoutFilter final : public HitFilter {
 public:
  explicit CutoutFilter(std::shared_ptr<const SurfaceTextures> textures)
      : textures_(std::move(textures)) {}
  bool filtered(uint32_t triangle) const override { return textures_->isCutout(triangle); }
  bool stops(uint32_t triangle, float u, float v, const Ray& ray) const override;

 private:
  std::shared_ptr<const SurfaceTextures> textures_;
};

// The filter for the scene's cut-outs, or null when no ray can pass through any triangle.
std::shared_ptr<const HitFilter> cutoutFilter(std::shared_ptr<const SurfaceTextures> textures);

// The textures of a scene (flattenScene's triangle order) when rays can pass through some
// triangle, else null: what the CPU filter and the GPU test (gpu_cutouts.h) read.
std::shared_ptr<const SurfaceTextures> sceneCutoutTextures(const Scene& scene);

// The filter for a scene's cut-outs, or null.
std::shared_ptr<const HitFilter> sceneCutouts(const Scene& scene);

// A uniform number in [0, 1) from a ray and a triangle (the blend decision).
float rayHashUniform(const Ray& ray, uint32_t triangle);

}  // namespace penumbra
