// Delta lights, in radiometric units. Emissive geometry is not a Light: it is a Material with
// emission on a mesh.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/scene/luminaire.h"

#include <glm/vec3.hpp>

#include <algorithm>
#include <cmath>

#include <span>
#include <variant>
#include <vector>

namespace penumbra {

// Isotropic point light: radiant intensity I (W sr^-1) in every direction.
struct PointLight {
  glm::vec3 position{0.0f};
  glm::vec3 intensity{1.0f};
};

// Spot light: intensity I on the axis, full inside `inner_angle`, smooth fall-off to zero at
// `outer_angle` (half-angles, radians), with the glTF KHR_lights_punctual attenuation
// clamp((cos a - cos outer) / (cos inner - cos outer), 0, 1)^2.
struct SpotLight {
  glm::vec3 position{0.0f};
  glm::vec3 direction{0.0f, -1.0f, 0.0f};  // unit, the way the light points
  glm::vec3 intensity{1.0f};
  float inner_angle = 0.0f;
  float outer_angle = 0.7853981634f;
};

// The glTF KHR_lights_punctual cone fall-off of a spot at angle cos_a from its axis,
//   s(a) = clamp((cos a - cos outer) / (cos inner - cos outer), 0, 1)^2,
// the one definition the path tracer and the radiosity methods use.
inline double spotFalloff(const SpotLight& spot, double cos_a) {
  const double cos_outer = std::cos(double(spot.outer_angle));
  const double scale = 1.0 / std::max(1e-3, std::cos(double(spot.inner_angle)) - cos_outer);
  const double a = std::clamp((cos_a - cos_outer) * scale, 0.0, 1.0);
  return a * a;
}

// Distant light: irradiance E (W m^-2) on a surface facing it, arriving along `direction`.
struct DirectionalLight {
  glm::vec3 direction{0.0f, -1.0f, 0.0f};  // unit, the way the light travels
  glm::vec3 irradiance{1.0f};
};

// Every kind of light. Code that treats kinds differently dispatches with std::visit and
// `Overloaded` (below), one handler per kind, so that a new kind cannot fall through unnoticed: a
// visitor without a handler for it does not compile.
using Light = std::variant<PointLight, SpotLight, DirectionalLight, LuminaireLight>;

// A visitor from one lambda per kind: std::visit(Overloaded{[](const PointLight&) {...}, ...}, l).
template <typename... Handlers>
struct Overloaded : Handlers... {
  using Handlers::operator()...;
};
template <typename... Handlers>
Overloaded(Handlers...) -> Overloaded<Handlers...>;

// The lights turned by `angle` radians about the vertical (+y) axis through `centre`: positions
// and directions alike (a light orbiting the scene, for relit sequences).
std::vector<Light> orbitLights(std::span<const Light> lights, const glm::vec3& centre, float angle);

// The largest intensity (W sr^-1), irradiance (W m^-2) or emission a scene may state: beyond
// it single-precision sums over a few bounces overflow.
inline constexpr float kMaxRadiometricValue = 1e15f;
// Lights stand at most this many scene radii from the scene's centre: farther, squared distances
// overflow single precision.
inline constexpr double kLightReach = 1e6;

// The most lights a scene may hold, whatever their source (arrays, files, scripts): the direct
// light at every shading point visits each of them (raytrace/direct_light.h), so a scene of a
// million lamps from a few lines of JSON would take hours for a thumbnail.
inline constexpr size_t kMaxSceneLights = 10000;

// Every light's numbers as the methods will use them (single precision, after transforms):
// positions finite and within kLightReach scene radii of `centre`, directions finite and not
// zero, intensities, irradiances and luminaire scales finite, non-negative and at most
// kMaxRadiometricValue, spot angles in [0, pi/2] with inner <= outer. Errors name `source` and
// the light ("light 3 (spot)"). More than kMaxSceneLights lights are refused.
Status checkLights(std::span<const Light> lights, const glm::vec3& centre, float radius,
                   const std::string& source);

}  // namespace penumbra
