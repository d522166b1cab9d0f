// Light from outside the scene at the radiosity methods' elements: the sky (scene/sky.h) with its
// ground, seen through the openings or straight, or the uniform environment (Scene::environment).
// Matrix, progressive and stochastic radiosity take it as direct irradiance at every element, as
// they take the lights' (the sun is one of those: a DirectionalLight in Scene::lights), on the CPU
// for both devices; their GPU solvers start from it as from the lights.
//
// The irradiance at element e (point x, face normal n), per RGB channel (W m^-2), is
//   S(x) = int over H(n) of  L_out(w) V_out(x, w) cos(theta) dw,                          (1)
// L_out(w) what a ray leaving the scene along w sees: the sky above the horizon and the ground
// below it (ISO 15469 luminance, scene/sky.h; rho_g E / pi for the ground), or L_env in every
// direction; V_out(x, w) = 1 when the ray from x leaves the scene, with the glazing's
// transmittance where it crosses an opening. Two disjoint parts estimate it:
//  - through the openings (a sky with openings): OpeningLight::irradiance, the portal estimator
//    of raytrace/daylight_gather.h, kOutsideSamples points over the openings (Lambert's closed
//    form factor per opening triangle times the mean of k tau L V; exact for a uniform sky seen
//    through an unobstructed opening);
//  - straight: kOutsideSamples cosine-distributed rays (multi-jittered); with pdf cos(theta) / pi,
//      S_straight = (pi / N) sum_k L_out(w_k) V(x, w_k),                                    (2)
//    rays that cross an opening left out (the portals counted them). Inside a room this is 0;
//    outside surfaces (an overhang, a facade opposite; CIE 171:2006 cases 5.13, 5.14), an outdoor
//    scene, or any surface under an environment get all of (1) from it. Under a uniform L_env
//    every ray that escapes brings exactly pi L_env / N: an unoccluded element gets pi L_env.
// A scene has a sky or an environment, not both (docs/scene-format.md): with a sky the
// environment is not seen, as in the path tracer. Each element draws from its own random stream,
// so the result depends on neither the thread count nor the ranks.
#pragma once

#include "penumbra/radiosity/radiosity_surface.h"
#include "penumbra/raytrace/daylight_gather.h"
#include "penumbra/scene/scene.h"

#include <glm/vec3.hpp>

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

namespace penumbra {

// Points over the openings, and cosine rays, per element.
inline constexpr int kOutsideSamples = 64;

// Whether element e takes no part in the books of light from outside: black and wholly covered,
// it absorbs everything that arrives on arrival, and nothing of it enters the solve. Counting
// what it receives as emitted would let a black facade or surround, lit over its whole area, make
// a room's own light look shot (progressive radiosity stopped a sunlit room behind a 2 m window
// in a 204 m black facade with its ceiling 9-16% dark).
bool absorbsOnArrival(const RadiositySurface& surface, size_t e);

// The power an irradiance per element brings to the surface, sum_e E_e A_e c_e (W per channel;
// c_e the element's coverage: a cut-out intercepts its covered share).
glm::dvec3 arrivingPower(const RadiositySurface& surface, std::span<const glm::dvec3> irradiance);

class OutsideLight {
 public:
  explicit OutsideLight(const Scene& scene);

  // Whether anything comes from outside: a sky, or an environment that is not black.
  bool active() const { return daylight_.has_value() || environment_ != glm::dvec3(0.0); }
  bool hasSky() const { return daylight_.has_value(); }

  // S(x) of eq. (1) at element e of `surface` (W m^-2), from its own random stream; the rays
  // traced are added to `rays`.
  glm::dvec3 irradianceAt(const RadiositySurface& surface, size_t e, uint64_t& rays) const;
  // At every element, in parallel; elements that absorb on arrival (absorbsOnArrival) are left
  // at zero. The rays traced are added to *rays.
  std::vector<glm::dvec3> irradiance(const RadiositySurface& surface,
                                     uint64_t* rays = nullptr) const;

 private:
  std::optional<OpeningLight> daylight_;  // with a sky
  glm::dvec3 environment_{0.0};           // without one
};

}  // namespace penumbra
