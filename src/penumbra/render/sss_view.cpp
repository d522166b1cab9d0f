#include "penumbra/render/sss_view.h"

#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/geometry/shading_normals.h"
#include "penumbra/kernels/dipole.h"
#include "penumbra/raytrace/camera_rays.h"
#include "penumbra/raytrace/lights.h"
#include "penumbra/render/lightmap_view.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <atomic>
#include <numbers>

namespace penumbra {

SssView SssView::trace(const SssSolver& solver, const Camera& camera,
                       const SssViewSettings& settings) {
  SssView v;
  v.width_ = settings.width;
  v.height_ = settings.height;
  const RadiositySurface& s = solver.surface();
  const ChartAtlas& atlas = s.atlas;
  v.lift_ = float(s.lift);
  const std::vector<glm::vec3>& positions = s.flat.positions;
  const std::vector<glm::uvec3>& triangles = s.flat.triangles;
  // The face of each side of each triangle, -1 where the side has none.
  std::vector<int32_t> face_of(2 * triangles.size(), -1);
  for (size_t f = 0; f < atlas.faces.size(); ++f) {
    if (atlas.charts.face_chart[f] < 0) continue;
    face_of[2 * size_t(atlas.faces[f].triangle) + (atlas.faces[f].back ? 1 : 0)] = int32_t(f);
  }
  const std::vector<Material>& materials = solver.scene().materials;
  const std::vector<glm::vec3> corner_normal = cornerShadingNormals(solver.scene());
  const CameraRays rays(camera, settings.width, settings.height);
  v.emitted_.assign(size_t(settings.width) * size_t(settings.height), glm::vec3(0.0f));
  const float w = 1.0f / float(settings.spp);
  // Rows in parallel, each with its own lists, joined in row order.
  std::vector<std::vector<Translucent>> rows_t(size_t(settings.height));
  std::vector<std::vector<Opaque>> rows_o(size_t(settings.height));
  parallelRange(size_t(settings.height), 1, [&](size_t y0, size_t y1) {
    for (size_t y = y0; y < y1; ++y) {
      for (int x = 0; x < settings.width; ++x) {
        const uint32_t pixel = uint32_t(y * size_t(settings.width) + size_t(x));
        for (int k = 0; k < settings.spp; ++k) {
          const glm::vec2 j = pixelJitter(settings.seed, pixel, uint32_t(k), settings.spp);
          const Ray ray = rays.ray(float(x) + j.x, float(y) + j.y);
          const Hit hit = s.engine.intersect(ray);
          if (!hit.hit()) {
            v.emitted_[pixel] += solver.scene().environment * w;  // the sky
            continue;
          }
          const size_t t = size_t(hit.triangle);
          const glm::uvec3 tri = triangles[t];
          const glm::vec3 n = glm::normalize(
              glm::cross(positions[tri.y] - positions[tri.x], positions[tri.z] - positions[tri.x]));
          const bool back = glm::dot(ray.dir, n) >= 0.0f;
          const Material& m = materials[s.flat.material_ids[t]];
          if (!back && m.isEmissive()) v.emitted_[pixel] += m.emission * w;
          const int32_t f = face_of[2 * t + (back ? 1 : 0)];
          if (f < 0) continue;  // a side without elements: black
          const size_t c = 3 * size_t(f);
          const float b0 = 1.0f - hit.u - hit.v;
          if (m.subsurface) {
            const glm::vec2 uv =
                b0 * atlas.uvs[c] + hit.u * atlas.uvs[c + 1] + hit.v * atlas.uvs[c + 2];
            // theta_o from the interpolated shading normal of the point, as pass 1 uses it.
            const glm::vec3 ns =
                glm::normalize(b0 * corner_normal[3 * t] + hit.u * corner_normal[3 * t + 1] +
                               hit.v * corner_normal[3 * t + 2]);
            const float cos_o = std::max(0.0f, -glm::dot(ray.dir, ns));
            const float ft = float(fresnelTransmittance(m.subsurface->eta, cos_o));
            rows_t[y].push_back({pixel, uv, ft * w});
          } else if (m.reflectance != glm::vec3(0.0f)) {
            const glm::vec3 p = ray.origin + hit.t * ray.dir;
            rows_o[y].push_back({pixel, p, back ? -n : n, m.reflectance * w});
          }
        }
      }
    }
  });
  for (auto& r : rows_t) v.translucent_.insert(v.translucent_.end(), r.begin(), r.end());
  for (auto& r : rows_o) v.opaque_.insert(v.opaque_.end(), r.begin(), r.end());
  return v;
}

Image SssView::render(const SssSolver& solver, const Image& scattered_atlas,
                      std::span<const Light> lights, uint64_t* rays) const {
  Image image(width_, height_);
  image.pixels = emitted_;
  // Samples are in pixel order; each thread takes whole rows, so no pixel is written by two.
  parallelRange(size_t(height_), 4, [&](size_t y0, size_t y1) {
    const uint32_t first = uint32_t(y0 * size_t(width_)), last = uint32_t(y1 * size_t(width_));
    auto lo = std::lower_bound(translucent_.begin(), translucent_.end(), first,
                               [](const Translucent& t, uint32_t p) { return t.pixel < p; });
    for (auto it = lo; it != translucent_.end() && it->pixel < last; ++it) {
      image.pixels[it->pixel] += it->weight * sampleBilinear(scattered_atlas, it->uv);
    }
  });
  const RadiositySurface& s = solver.surface();
  std::atomic<uint64_t> traced{0};
  parallelRange(size_t(height_), 4, [&](size_t y0, size_t y1) {
    const uint32_t first = uint32_t(y0 * size_t(width_)), last = uint32_t(y1 * size_t(width_));
    auto lo = std::lower_bound(opaque_.begin(), opaque_.end(), first,
                               [](const Opaque& o, uint32_t p) { return o.pixel < p; });
    uint64_t count = 0;
    for (auto it = lo; it != opaque_.end() && it->pixel < last; ++it) {
      const glm::dvec3 e = visibleIrradiance(s.engine, double(lift_), lights, glm::dvec3(it->point),
                                             glm::dvec3(it->normal), &count);
      image.pixels[it->pixel] += it->reflectance * glm::vec3(e / std::numbers::pi);
    }
    traced += count;
  });
  if (rays) *rays += traced.load();
  return image;
}

}  // namespace penumbra
