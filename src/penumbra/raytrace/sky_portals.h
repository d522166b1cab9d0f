// The openings of a daylit scene (scene/sky.h) as portals for the path tracer's next-event
// estimation: at a diffuse vertex a point y is drawn on the openings, uniform over their area,
// and the sky (or ground) beyond along x -> y is taken if nothing stands in the way, with the
// glazing it crosses. In solid angle the sample's density is
//   p(w) = sum over the opening triangles the ray x + t w crosses of  r^2 / (|cos theta_y| A),
// A the openings' whole area. BSDF sampling finds the same light when its ray escapes; the two
// are combined by the power heuristic (Veach 1997, ch. 9), the escaping ray weighted with the
// same p(w). Bitterli et al.'s "Portal-masked environment map sampling" (2015) is the general
// form; the uniform-area density here suits the small windows and roof lights of rooms, where
// BSDF sampling alone finds the sky with a probability of the openings' solid angle.
#pragma once

#include "penumbra/kernels/sampling.h"
#include "penumbra/raytrace/direct_light.h"
#include "penumbra/scene/sky.h"

#include <glm/vec3.hpp>

#include <cmath>
#include <cstdint>
#include <optional>
#include <vector>

namespace penumbra {

class SkyPortals {
 public:
  SkyPortals() = default;
  // The openings' triangles (each polygon fanned from its first corner), when there is a sky.
  SkyPortals(const std::optional<Sky>& sky, const std::vector<Opening>& openings);

  bool active() const { return total_area_ > 0.0; }

  // The density in solid angle of direction `w` (unit) from `x` under the sampling above; 0 when
  // the ray crosses no opening.
  float pdf(const glm::vec3& x, const glm::vec3& w) const;

  // The portal sample at p (ray offset p_offset, normal n facing the outgoing side, reflectance
  // rho) from the 2-D point (u1, u2): a shadow query along the sampled direction to infinity,
  // carrying rho / pi L cos / pdf, MIS-weighted against cosine sampling when `mis`. `radiance`
  // is what the ray meets beyond, given its direction (the sky through the glazing). False
  // when the point faces away.
  template <typename Radiance>
  bool query(const glm::vec3& p, float p_offset, const glm::vec3& n, const glm::vec3& rho, float u1,
             float u2, bool mis, Radiance&& radiance, ShadowQuery& out) const;

 private:
  struct Tri {
    glm::vec3 a, b, c, normal;
    float area;
  };
  std::vector<Tri> tris_;
  std::vector<double> cdf_;  // cumulative area
  double total_area_ = 0.0;

  // A point uniform over the openings' area from (u1, u2), and its triangle's normal.
  glm::vec3 point(float u1, float u2, glm::vec3& normal) const;
};

template <typename Radiance>
bool SkyPortals::query(const glm::vec3& p, float p_offset, const glm::vec3& n, const glm::vec3& rho,
                       float u1, float u2, bool mis, Radiance&& radiance, ShadowQuery& out) const {
  if (!active()) return false;
  glm::vec3 ny;
  const glm::vec3 y = point(u1, u2, ny);
  const glm::vec3 d = y - p;
  const float d2 = glm::dot(d, d);
  if (!(d2 > 0.0f)) return false;
  const glm::vec3 wi = d / std::sqrt(d2);
  const float cos_s = glm::dot(n, wi);
  if (cos_s <= 0.0f) return false;
  const float pdf_light = pdf(p, wi);
  if (!(pdf_light > 0.0f)) return false;
  const glm::vec3 l = radiance(wi);
  if (l == glm::vec3(0.0f)) return false;
  const float w = mis ? powerHeuristic(pdf_light, cos_s * kInvPi) : 1.0f;
  out = ShadowQuery{Ray{offsetOrigin(p, p_offset, n, wi), 0.0f, wi, kRayInfinity},
                    rho * kInvPi * l * cos_s * w / pdf_light, true};
  return true;
}

}  // namespace penumbra
