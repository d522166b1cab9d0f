#include "penumbra/render/lightmap_view.h"

#include "penumbra/core/check.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/raytrace/camera_rays.h"
#include "penumbra/raytrace/cutout_filter.h"
#include "penumbra/raytrace/ray_engine.h"

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>

namespace penumbra {

glm::vec3 sampleBilinear(const Image& lightmap, glm::vec2 uv) {
  // Texel (x, y) has its centre at ((x + 0.5) / width, (y + 0.5) / height).
  const float fx = uv.x * float(lightmap.width) - 0.5f, fy = uv.y * float(lightmap.height) - 0.5f;
  const float x0f = std::floor(fx), y0f = std::floor(fy);
  const float tx = fx - x0f, ty = fy - y0f;
  auto at = [&](int x, int y) {
    x = glm::clamp(x, 0, lightmap.width - 1);
    y = glm::clamp(y, 0, lightmap.height - 1);
    return lightmap.at(x, y);
  };
  const int x0 = int(x0f), y0 = int(y0f);
  return (1.0f - ty) * ((1.0f - tx) * at(x0, y0) + tx * at(x0 + 1, y0)) +
         ty * ((1.0f - tx) * at(x0, y0 + 1) + tx * at(x0 + 1, y0 + 1));
}

LightmapLookup::LightmapLookup(std::span<const glm::vec3> positions,
                               std::span<const glm::uvec3> triangles, const ChartAtlas& atlas,
                               const Image& lightmap, const LightmapDetail* detail)
    : positions_(positions),
      triangles_(triangles),
      atlas_(&atlas),
      lightmap_(&lightmap),
      detail_(detail && detail->textures && detail->textures->any() ? detail : nullptr) {
  PENUMBRA_CHECK(atlas.uvs.size() == 3 * atlas.faces.size());
  PENUMBRA_CHECK(lightmap.width == atlas.width && lightmap.height == atlas.height);
  face_of_.assign(2 * triangles.size(), -1);
  for (size_t f = 0; f < atlas.faces.size(); ++f) {
    if (atlas.charts.face_chart[f] < 0) continue;
    face_of_[2 * size_t(atlas.faces[f].triangle) + (atlas.faces[f].back ? 1 : 0)] = int32_t(f);
  }
}

glm::vec3 LightmapLookup::radiance(const glm::vec3& ray_dir, int32_t triangle, float u,
                                   float v) const {
  if (triangle < 0) return glm::vec3(0.0f);
  const size_t t = size_t(triangle);
  const glm::uvec3 tri = triangles_[t];
  const glm::vec3 n =
      glm::cross(positions_[tri.y] - positions_[tri.x], positions_[tri.z] - positions_[tri.x]);
  const int32_t f = face_of_[2 * t + (glm::dot(ray_dir, n) >= 0.0f ? 1 : 0)];
  if (f < 0) return glm::vec3(0.0f);  // a side without elements: black
  const size_t c = 3 * size_t(f);
  const glm::vec2 uv =
      (1.0f - u - v) * atlas_->uvs[c] + u * atlas_->uvs[c + 1] + v * atlas_->uvs[c + 2];
  const glm::vec3 l = sampleBilinear(*lightmap_, uv);
  if (!detail_ || !detail_->textures->varies(uint32_t(t))) return l;
  // The texture's detail: the lightmap's irradiance (its mean albedo divided out) times the
  // albedo at the hit, plus the emission at the hit.
  const glm::vec3 rho_mean = sampleBilinear(detail_->mean_reflectance, uv);
  const glm::vec3 le_mean = sampleBilinear(detail_->mean_emission, uv);
  const glm::vec2 b(u, v);
  const glm::vec3 rho = detail_->textures->reflectance(uint32_t(t), b);
  const bool front = atlas_->faces[size_t(f)].back == false;
  const glm::vec3 le = front ? detail_->textures->emission(uint32_t(t), b) : glm::vec3(0.0f);
  glm::vec3 out;
  for (int k = 0; k < 3; ++k) {
    // A texel that reflects (almost) nothing on average keeps the lightmap's value.
    out[k] = rho_mean[k] > 1e-4f ? rho[k] * std::max(l[k] - le_mean[k], 0.0f) / rho_mean[k] + le[k]
                                 : l[k] - le_mean[k] + le[k];
  }
  return glm::max(out, glm::vec3(0.0f));
}

namespace {

// Sample s of pixel (x, y): its ray through the pixel's stratified jitter (raytrace/camera_rays.h:
// pixelJitter; the pixel's centre for one sample per pixel).
Ray viewRay(const CameraRays& rays, const LightmapViewSettings& settings, int x, int y, int s) {
  const uint64_t pixel = uint64_t(y) * uint64_t(settings.width) + uint64_t(x);
  const glm::vec2 j = pixelJitter(settings.seed, pixel, uint32_t(s), settings.spp);
  return rays.ray(float(x) + j.x, float(y) + j.y);
}

}  // namespace

LightmapView::LightmapView(std::span<const glm::vec3> positions,
                           std::span<const glm::uvec3> triangles, const ChartAtlas& atlas,
                           const Camera& camera, const LightmapViewSettings& settings,
                           const LightmapDetail* detail)
    : positions_(positions),
      triangles_(triangles),
      atlas_(&atlas),
      settings_(settings),
      detail_(detail) {
  RayEngine engine = RayEngine::build(positions, triangles);
  if (detail) engine.setHitFilter(cutoutFilter(detail->textures));
  const CameraRays rays(camera, settings.width, settings.height);
  const size_t spp = size_t(settings.spp);
  samples_.resize(size_t(settings.width) * size_t(settings.height) * spp);
  parallelRange(size_t(settings.height), 1, [&](size_t y0, size_t y1) {
    for (size_t y = y0; y < y1; ++y) {
      for (int x = 0; x < settings.width; ++x) {
        Sample* out = samples_.data() + (y * size_t(settings.width) + size_t(x)) * spp;
        for (size_t s = 0; s < spp; ++s) {
          const Ray ray = viewRay(rays, settings, x, int(y), int(s));
          const Hit hit = engine.intersect(ray);
          out[s] = {ray.dir, hit.triangle, hit.u, hit.v};
        }
      }
    }
  });
}

Image LightmapView::render(const Image& lightmap) const {
  const LightmapLookup lookup(positions_, triangles_, *atlas_, lightmap, detail_);
  Image image(settings_.width, settings_.height);
  const size_t spp = size_t(settings_.spp);
  parallelRange(image.pixels.size(), 1024, [&](size_t p0, size_t p1) {
    for (size_t p = p0; p < p1; ++p) {
      glm::vec3 sum(0.0f);
      for (size_t s = 0; s < spp; ++s) {
        const Sample& h = samples_[p * spp + s];
        sum += lookup.radiance(h.dir, h.triangle, h.u, h.v);
      }
      image.pixels[p] = sum / float(settings_.spp);
    }
  });
  return image;
}

Image renderLightmapView(std::span<const glm::vec3> positions,
                         std::span<const glm::uvec3> triangles, const ChartAtlas& atlas,
                         const Image& lightmap, const Camera& camera,
                         const LightmapViewSettings& settings, const LightmapDetail* detail) {
  const LightmapLookup lookup(positions, triangles, atlas, lightmap, detail);
  RayEngine engine = RayEngine::build(positions, triangles);
  if (detail) engine.setHitFilter(cutoutFilter(detail->textures));
  const CameraRays rays(camera, settings.width, settings.height);
  Image image(settings.width, settings.height);
  parallelRange(size_t(settings.height), 1, [&](size_t y0, size_t y1) {
    for (size_t y = y0; y < y1; ++y) {
      for (int x = 0; x < settings.width; ++x) {
        glm::vec3 sum(0.0f);
        for (int s = 0; s < settings.spp; ++s) {
          const Ray ray = viewRay(rays, settings, x, int(y), s);
          const Hit hit = engine.intersect(ray);
          sum += lookup.radiance(ray.dir, hit.triangle, hit.u, hit.v);
        }
        image.at(x, int(y)) = sum / float(settings.spp);
      }
    }
  });
  return image;
}

}  // namespace penumbra
