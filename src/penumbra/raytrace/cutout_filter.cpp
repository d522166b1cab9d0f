#include "penumbra/raytrace/cutout_filter.h"

#include "penumbra/core/rng.h"

#include <bit>
#include <cstdint>

namespace penumbra {

float rayHashUniform(const Ray& ray, uint32_t triangle) {
  uint32_t h = mixBits32(triangle + 0x9e3779b9u);
  for (const float f :
       {ray.origin.x, ray.origin.y, ray.origin.z, ray.dir.x, ray.dir.y, ray.dir.z}) {
    h = mixBits32(h ^ std::bit_cast<uint32_t>(f));
  }
  return float(h >> 8) * 0x1p-24f;
}

bool CutoutFilter::stops(uint32_t triangle, float u, float v, const Ray& ray) const {
  return textures_->stops(triangle, glm::vec2(u, v), rayHashUniform(ray, triangle));
}

std::shared_ptr<const HitFilter> cutoutFilter(std::shared_ptr<const SurfaceTextures> textures) {
  if (!textures || !textures->hasCutouts()) return nullptr;
  return std::make_shared<const CutoutFilter>(std::move(textures));
}

std::shared_ptr<const SurfaceTextures> sceneCutoutTextures(const Scene& scene) {
  bool any = false;
  for (const Material& m : scene.materials) any = any || m.alpha_mode != AlphaMode::kOpaque;
  if (!any) return nullptr;
  auto textures = std::make_shared<const SurfaceTextures>(scene);
  return textures->hasCutouts() ? textures : nullptr;
}

std::shared_ptr<const HitFilter> sceneCutouts(const Scene& scene) {
  return cutoutFilter(sceneCutoutTextures(scene));
}

}  // namespace penumbra
