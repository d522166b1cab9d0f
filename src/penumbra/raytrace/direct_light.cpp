#include "penumbra/raytrace/direct_light.h"

#include "penumbra/kernels/sampling.h"

#include <cmath>
#include <variant>

namespace penumbra {

namespace {

// Shadow rays stop this fraction short of their target, so they do not hit the light's own
// surface.
constexpr float kShadowShorten = 1.0f - 1e-5f;

}  // namespace

ShadowQuery shadowTo(const glm::vec3& p, float p_offset, const glm::vec3& n,
                     const glm::vec3& target, const glm::vec3& value) {
  const glm::vec3 origin = offsetOrigin(p, p_offset, n, target - p);
  const glm::vec3 d = target - origin;
  const float dist = glm::length(d);
  if (!(dist > 0.0f)) return ShadowQuery{Ray{}, value, false};
  return ShadowQuery{Ray{origin, 0.0f, d / dist, dist * kShadowShorten}, value, true};
}

int deltaLightQueries(std::span<const Light> lights, const glm::vec3& p, float p_offset,
                      const glm::vec3& n, const glm::vec3& rho, ShadowQuery* out) {
  const glm::vec3 f = rho * kInvPi;  // Lambertian BRDF
  int count = 0;
  // Delta lights: one shadow ray each. Geometric terms are taken at the surface point p; the
  // shadow ray starts from p lifted off the surface.
  const auto point_like = [&](const glm::vec3& pos, auto&& intensity_towards) {
    const glm::vec3 d = pos - p;
    const float d2 = glm::dot(d, d);
    if (!(d2 > 0.0f)) return;
    const glm::vec3 wi = d / std::sqrt(d2);
    const float cos_s = glm::dot(n, wi);
    if (cos_s <= 0.0f) return;
    const glm::vec3 intensity = intensity_towards(-wi);
    if (intensity == glm::vec3(0.0f)) return;
    out[count++] = shadowTo(p, p_offset, n, pos, f * intensity * cos_s / d2);
  };
  for (const Light& light : lights) {
    std::visit(
        Overloaded{[&](const DirectionalLight& dl) {
                     const glm::vec3 wi = -dl.direction;
                     const float cos_s = glm::dot(n, wi);
                     if (cos_s <= 0.0f) return;
                     out[count++] =
                         ShadowQuery{Ray{offsetOrigin(p, p_offset, n, wi), 0.0f, wi, kRayInfinity},
                                     f * dl.irradiance * cos_s, true};
                   },
                   [&](const PointLight& pl) {
                     point_like(pl.position, [&](const glm::vec3&) { return pl.intensity; });
                   },
                   [&](const SpotLight& sl) {
                     point_like(sl.position, [&](const glm::vec3& out_dir) {
                       return sl.intensity *
                              float(spotFalloff(sl, double(glm::dot(sl.direction, out_dir))));
                     });
                   },
                   [&](const LuminaireLight& lu) {
                     // Its light distribution towards p (scene/luminaire.h, Wallner eq. 15).
                     point_like(lu.position, [&](const glm::vec3& out_dir) {
                       return luminaireIntensity(lu, out_dir);
                     });
                   }},
        light);
  }
  return count;
}

bool emitterQuery(const SceneGeometry& g, const glm::vec3& p, float p_offset, const glm::vec3& n,
                  const glm::vec3& rho, uint32_t u_x, float u_y, bool mis, float weight,
                  ShadowQuery& out) {
  if (g.emitters.empty()) return false;
  const EmitterPick pick = g.pickEmitter(u_x);
  const uint32_t tri = g.emitters[pick.index];
  const glm::vec2 b = sampleTriangleBarycentrics(pick.u, u_y);
  const glm::vec3 q = g.point(tri, b.x, b.y);
  const glm::vec3 d = q - p;
  const float d2 = glm::dot(d, d);
  if (!(d2 > 0.0f)) return false;
  const glm::vec3 wi = d / std::sqrt(d2);
  const float cos_s = glm::dot(n, wi);
  const glm::vec3& nl = g.normals[tri];
  const float cos_l = -glm::dot(nl, wi);  // emits from the front only
  if (cos_s <= 0.0f || cos_l <= 0.0f) return false;
  const float pdf_area = g.emitter_pick_pdf[tri] / g.areas[tri];
  const float pdf_light = pdf_area * d2 / cos_l;  // solid-angle measure
  const float pdf_bsdf = cos_s * kInvPi;
  const glm::vec3 le = g.emissionSampled(tri, b.x, b.y);
  if (le == glm::vec3(0.0f)) return false;
  const float w = weight * (mis ? powerHeuristic(pdf_light, pdf_bsdf) : 1.0f);
  // Aim at q lifted off the light towards p, so the shadow ray cannot hit the light itself.
  const glm::vec3 target = offsetOrigin(q, g.surfaceOffset(tri), nl, -d);
  out = shadowTo(p, p_offset, n, target, rho * kInvPi * le * cos_s * w / pdf_light);
  return true;
}

}  // namespace penumbra
