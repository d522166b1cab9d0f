// Lambertian materials. Reflectance is the hemispherical reflectance rho in [0, 1) per RGB
// channel (the BRDF is rho / pi); emission is the radiance leaving the front face
// (W m^-2 sr^-1, the side the counter-clockwise winding faces). Surfaces reflect on both sides
// unless `two_sided` is false (glTF's doubleSided = false, or "two_sided": false in a JSON
// scene): then the back face is black in every method: it reflects and emits nothing, and the
// radiosity methods give it no elements.
#pragma once

#include <glm/vec3.hpp>

#include <string>

namespace penumbra {

struct Material {
  std::string name;
  glm::vec3 reflectance{0.8f};
  glm::vec3 emission{0.0f};
  bool two_sided = true;

  bool isEmissive() const { return emission.x > 0.0f || emission.y > 0.0f || emission.z > 0.0f; }
};

}  // namespace penumbra
