#include "penumbra/render/element_view.h"

#include "penumbra/core/check.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/raytrace/camera_rays.h"
#include "penumbra/raytrace/ray_engine.h"

#include <glm/geometric.hpp>

namespace penumbra {

Image renderElementView(const Elements& elements, std::span<const glm::vec3> corner_radiance,
                        const Camera& camera, const ElementViewSettings& settings) {
  PENUMBRA_CHECK(corner_radiance.size() == 3 * elements.size());
  const RayEngine engine = RayEngine::build(elements.positions, elements.triangles);
  const CameraRays rays(camera, settings.width, settings.height);
  Image image(settings.width, settings.height);
  parallelRange(size_t(settings.height), 1, [&](size_t y0, size_t y1) {
    for (size_t y = y0; y < y1; ++y) {
      for (int x = 0; x < settings.width; ++x) {
        const uint64_t pixel = y * uint64_t(settings.width) + uint64_t(x);
        Rng rng(mixBits(settings.seed), pixel);
        glm::vec3 sum(0.0f);
        for (int s = 0; s < settings.spp; ++s) {
          const float jx = settings.spp == 1 ? 0.5f : rng.uniform();
          const float jy = settings.spp == 1 ? 0.5f : rng.uniform();
          const Ray ray = rays.ray(float(x) + jx, float(y) + jy);
          const Hit hit = engine.intersect(ray);
          if (!hit.hit()) continue;
          const size_t e = size_t(hit.triangle);
          if (glm::dot(ray.dir, elements.normal[e]) >= 0.0f) continue;  // the unlit back
          sum += (1.0f - hit.u - hit.v) * corner_radiance[3 * e] +
                 hit.u * corner_radiance[3 * e + 1] + hit.v * corner_radiance[3 * e + 2];
        }
        image.at(x, int(y)) = sum / float(settings.spp);
      }
    }
  });
  return image;
}

}  // namespace penumbra
