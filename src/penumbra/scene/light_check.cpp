#include "penumbra/scene/light.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include <cmath>
#include <numbers>
#include <string>

namespace penumbra {

namespace {

bool finite3(const glm::vec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

std::string text(const glm::vec3& v) {
  return fmt::format("({:g}, {:g}, {:g})", v.x, v.y, v.z);
}

struct LightCheck {
  glm::vec3 centre;
  double reach;  // m
  const std::string& source;
  std::string place;

  Status position(const glm::vec3& p) const {
    if (!finite3(p) || double(glm::length(p - centre)) > reach) {
      return inputError(source, place,
                        fmt::format("position {} must be finite and within {:g} m of the scene "
                                    "(10^6 times its radius)",
                                    text(p), reach));
    }
    return {};
  }
  Status direction(const glm::vec3& d, const char* what) const {
    if (!finite3(d) || !(glm::dot(d, d) > 0.0f)) {
      return inputError(source, place,
                        fmt::format("{} {} must be finite and not zero", what, text(d)));
    }
    return {};
  }
  Status power(const glm::vec3& v, const char* what) const {
    if (!finite3(v) || glm::any(glm::lessThan(v, glm::vec3(0.0f))) ||
        glm::any(glm::greaterThan(v, glm::vec3(kMaxRadiometricValue)))) {
      return inputError(source, place,
                        fmt::format("{} {} must be finite, non-negative and at most {:g}", what,
                                    text(v), kMaxRadiometricValue));
    }
    return {};
  }
};

}  // namespace

Status checkLights(std::span<const Light> lights, const glm::vec3& centre, float radius,
                   const std::string& source) {
  if (lights.size() > kMaxSceneLights) {
    return inputError(source, "lights",
                      fmt::format("{} lights; a scene may hold at most {} (the direct light "
                                  "visits every one at every shading point)",
                                  lights.size(), kMaxSceneLights));
  }
  const double reach = kLightReach * std::max(double(radius), 1e-3);
  for (size_t i = 0; i < lights.size(); ++i) {
    LightCheck c{centre, reach, source, ""};
    const Status s = std::visit(
        Overloaded{[&](const PointLight& p) -> Status {
                     c.place = fmt::format("light {} (point)", i);
                     PENUMBRA_TRY(c.position(p.position));
                     return c.power(p.intensity, "intensity");
                   },
                   [&](const SpotLight& sp) -> Status {
                     c.place = fmt::format("light {} (spot)", i);
                     PENUMBRA_TRY(c.position(sp.position));
                     PENUMBRA_TRY(c.direction(sp.direction, "direction"));
                     PENUMBRA_TRY(c.power(sp.intensity, "intensity"));
                     const float half_pi = 0.5f * std::numbers::pi_v<float>;
                     if (!(sp.inner_angle >= 0.0f && sp.inner_angle <= sp.outer_angle &&
                           sp.outer_angle <= half_pi * (1.0f + 1e-6f))) {
                       return inputError(
                           source, c.place,
                           fmt::format("cone angles {:g} and {:g} rad must satisfy 0 <= inner "
                                       "<= outer <= pi/2",
                                       sp.inner_angle, sp.outer_angle));
                     }
                     return {};
                   },
                   [&](const DirectionalLight& d) -> Status {
                     c.place = fmt::format("light {} (directional)", i);
                     PENUMBRA_TRY(c.direction(d.direction, "direction"));
                     return c.power(d.irradiance, "irradiance");
                   },
                   [&](const LuminaireLight& l) -> Status {
                     c.place = fmt::format("light {} (luminaire)", i);
                     PENUMBRA_TRY(c.position(l.position));
                     PENUMBRA_TRY(c.direction(l.nadir, "nadir"));
                     PENUMBRA_TRY(c.direction(l.c0, "C0 direction"));
                     return c.power(l.scale, "scale");
                   }},
        lights[i]);
    PENUMBRA_TRY(s);
  }
  return {};
}

}  // namespace penumbra
