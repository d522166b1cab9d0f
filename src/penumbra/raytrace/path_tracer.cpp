#include "penumbra/raytrace/path_tracer.h"

#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/kernels/sampling.h"
#include "penumbra/raytrace/camera_rays.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <variant>

namespace penumbra {

namespace {

constexpr float kInfinity = std::numeric_limits<float>::infinity();

// Moves a surface point off its surface by `offset` (SceneGeometry::surfaceOffset) along the
// normal, to the side of `dir`.
inline glm::vec3 offsetOrigin(const glm::vec3& p, float offset, const glm::vec3& n,
                              const glm::vec3& dir) {
  return p + (glm::dot(n, dir) >= 0.0f ? offset : -offset) * n;
}

// Shadow rays stop this fraction short of their target, so they do not hit the light's own
// surface.
constexpr float kShadowShorten = 1.0f - 1e-5f;

// glTF KHR_lights_punctual spot attenuation.
inline float spotFalloff(const SpotLight& s, const glm::vec3& to_point) {
  const float cos_outer = std::cos(s.outer_angle), cos_inner = std::cos(s.inner_angle);
  const float cd = glm::dot(s.direction, to_point);
  const float scale = 1.0f / std::max(1e-3f, cos_inner - cos_outer);
  const float a = std::clamp((cd - cos_outer) * scale, 0.0f, 1.0f);
  return a * a;
}

}  // namespace

PathTracer::PathTracer(const Scene& scene)
    : geometry_(SceneGeometry::build(scene)), lights_(scene.lights) {}

bool PathTracer::visible(const glm::vec3& p, float p_offset, const glm::vec3& n,
                         const glm::vec3& target, uint64_t& rays) const {
  const glm::vec3 origin = offsetOrigin(p, p_offset, n, target - p);
  const glm::vec3 d = target - origin;
  const float dist = glm::length(d);
  if (!(dist > 0.0f)) return true;
  ++rays;
  return !geometry_.engine.occluded(Ray{origin, 0.0f, d / dist, dist * kShadowShorten});
}

glm::vec3 PathTracer::directLight(const glm::vec3& p, float p_offset, const glm::vec3& n,
                                  const glm::vec3& rho, Rng& rng, uint64_t& rays) const {
  const glm::vec3 f = rho * kInvPi;  // Lambertian BRDF
  glm::vec3 sum(0.0f);
  // Delta lights: one shadow ray each. Geometric terms are taken at the surface point p; the
  // shadow ray starts from p lifted off the surface.
  for (const Light& light : lights_) {
    if (const auto* dl = std::get_if<DirectionalLight>(&light)) {
      const glm::vec3 wi = -dl->direction;
      const float cos_s = glm::dot(n, wi);
      if (cos_s <= 0.0f) continue;
      ++rays;
      const Ray shadow{offsetOrigin(p, p_offset, n, wi), 0.0f, wi, kInfinity};
      if (!geometry_.engine.occluded(shadow)) sum += f * dl->irradiance * cos_s;
      continue;
    }
    const glm::vec3 pos = std::holds_alternative<PointLight>(light)
                              ? std::get<PointLight>(light).position
                              : std::get<SpotLight>(light).position;
    const glm::vec3 d = pos - p;
    const float d2 = glm::dot(d, d);
    const glm::vec3 wi = d / std::sqrt(d2);
    const float cos_s = glm::dot(n, wi);
    if (cos_s <= 0.0f || !(d2 > 0.0f)) continue;
    glm::vec3 intensity;
    if (const auto* sl = std::get_if<SpotLight>(&light)) {
      intensity = sl->intensity * spotFalloff(*sl, -wi);
    } else {
      intensity = std::get<PointLight>(light).intensity;
    }
    if (intensity == glm::vec3(0.0f)) continue;
    if (visible(p, p_offset, n, pos, rays)) sum += f * intensity * cos_s / d2;
  }
  // One sample of the emissive triangles, MIS-weighted against cosine sampling.
  if (!geometry_.emitters.empty()) {
    const uint32_t k = geometry_.pickEmitter(rng.uniform());
    const uint32_t tri = geometry_.emitters[k];
    const glm::vec2 b = sampleTriangleBarycentrics(rng.uniform(), rng.uniform());
    const glm::vec3 q = geometry_.point(tri, b.x, b.y);
    const glm::vec3 d = q - p;
    const float d2 = glm::dot(d, d);
    if (!(d2 > 0.0f)) return sum;
    const glm::vec3 wi = d / std::sqrt(d2);
    const float cos_s = glm::dot(n, wi);
    const glm::vec3& nl = geometry_.normals[tri];
    const float cos_l = -glm::dot(nl, wi);  // emits from the front only
    if (cos_s <= 0.0f || cos_l <= 0.0f) return sum;
    // Aim at q lifted off the light towards p, so the shadow ray cannot hit the light itself.
    const glm::vec3 target = offsetOrigin(q, geometry_.surfaceOffset(tri, b.x, b.y), nl, -d);
    if (visible(p, p_offset, n, target, rays)) {
      const float pdf_area = geometry_.emitter_pick_pdf[tri] / geometry_.areas[tri];
      const float pdf_light = pdf_area * d2 / cos_l;  // solid-angle measure
      const float pdf_bsdf = cos_s * kInvPi;
      const glm::vec3& le = geometry_.materials[geometry_.material_ids[tri]].emission;
      sum += f * le * cos_s * powerHeuristic(pdf_light, pdf_bsdf) / pdf_light;
    }
  }
  return sum;
}

glm::vec3 PathTracer::radiance(const Ray& primary, Rng& rng, const PathTracerSettings& settings,
                               uint64_t& rays) const {
  glm::vec3 result(0.0f), beta(1.0f);
  Ray ray = primary;
  float prev_bsdf_pdf = 0.0f;  // solid-angle pdf of the last bounce; 0 for the camera ray
  glm::vec3 prev_point(0.0f);
  for (int depth = 0;; ++depth) {
    ++rays;
    const Hit hit = geometry_.engine.intersect(ray);
    if (!hit.hit()) break;
    const uint32_t tri = uint32_t(hit.triangle);
    const Material& mat = geometry_.materials[geometry_.material_ids[tri]];
    const glm::vec3 ng = geometry_.normals[tri];
    const float cos_front = -glm::dot(ng, ray.dir) / glm::length(ray.dir);
    const glm::vec3 p = geometry_.point(tri, hit.u, hit.v);
    const float p_offset = geometry_.surfaceOffset(tri, hit.u, hit.v);

    // Emission reached by BSDF sampling (or seen directly), MIS-weighted against the emitter
    // sample taken at the previous vertex.
    if (mat.isEmissive() && cos_front > 0.0f) {
      float w = 1.0f;
      if (prev_bsdf_pdf > 0.0f && geometry_.emitter_pick_pdf[tri] > 0.0f) {
        const glm::vec3 d = p - prev_point;
        const float pdf_light =
            geometry_.emitter_pick_pdf[tri] / geometry_.areas[tri] * glm::dot(d, d) / cos_front;
        w = powerHeuristic(prev_bsdf_pdf, pdf_light);
      }
      result += beta * mat.emission * w;
    }
    if (settings.max_depth > 0 && depth >= settings.max_depth) break;
    if (mat.reflectance == glm::vec3(0.0f)) break;

    // Surfaces reflect on both sides: shade with the normal facing the incoming ray.
    const glm::vec3 n = cos_front > 0.0f ? ng : -ng;
    result += beta * directLight(p, p_offset, n, mat.reflectance, rng, rays);

    // Cosine-weighted bounce: f cos / pdf = rho.
    const glm::vec3 local = sampleCosineHemisphere(rng.uniform(), rng.uniform());
    const glm::vec3 wi = Frame::fromNormal(n).toWorld(local);
    const float cos_s = glm::dot(n, wi);
    if (cos_s <= 0.0f) break;
    beta *= mat.reflectance;
    prev_bsdf_pdf = cos_s * kInvPi;
    prev_point = p;

    // Russian roulette (unbiased): survive with probability min(max(beta), 0.99), so that
    // even reflectance 1 ends.
    if (depth + 1 >= settings.rr_start_depth) {
      const float survive = std::min(std::max({beta.x, beta.y, beta.z}), 0.99f);
      if (rng.uniform() >= survive) break;
      beta /= survive;
    }
    ray.origin = offsetOrigin(p, p_offset, n, wi);
    ray.dir = wi;
    ray.tmin = 0.0f;
    ray.tmax = kInfinity;
  }
  return result;
}

Image PathTracer::render(const Camera& camera, const PathTracerSettings& settings,
                         PathTracerStats* stats,
                         const std::function<void(int)>& on_progress) const {
  Timer timer;
  Image image(settings.width, settings.height);
  const CameraRays cam(camera, settings.width, settings.height);
  std::atomic<uint64_t> total_rays{0};
  std::atomic<int> rows_done{0};
  parallelRange(size_t(settings.height), 1, [&](size_t y0, size_t y1) {
    uint64_t rays = 0;
    for (size_t y = y0; y < y1; ++y) {
      for (int x = 0; x < settings.width; ++x) {
        const uint64_t pixel = uint64_t(y) * uint64_t(settings.width) + uint64_t(x);
        Rng rng(mixBits(settings.seed), pixel);
        glm::dvec3 sum(0.0);
        for (int s = 0; s < settings.spp; ++s) {
          const float jx = rng.uniform(), jy = rng.uniform();
          const Ray r = cam.ray(float(x) + jx, float(y) + jy);
          sum += glm::dvec3(radiance(r, rng, settings, rays));
        }
        image.at(x, int(y)) = glm::vec3(sum / double(settings.spp));
      }
      const int done = rows_done.fetch_add(1) + 1;
      if (on_progress) on_progress(done);
    }
    total_rays += rays;
  });
  if (stats) {
    stats->rays = total_rays.load();
    stats->seconds = timer.seconds();
  }
  return image;
}

}  // namespace penumbra
