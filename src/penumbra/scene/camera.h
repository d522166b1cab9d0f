// Pinhole camera. Image row 0 is the top; `up` need not be orthogonal to the view direction.
#pragma once

#include <glm/vec3.hpp>

namespace penumbra {

struct Camera {
  glm::vec3 position{0.0f, 0.0f, 1.0f};
  glm::vec3 look_at{0.0f};
  glm::vec3 up{0.0f, 1.0f, 0.0f};
  float vertical_fov = 0.6859f;  // radians (39.3 degrees: the Cornell camera)
};

}  // namespace penumbra
