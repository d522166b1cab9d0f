// Colour quantities every module shares.
#pragma once

#include <glm/vec3.hpp>

namespace penumbra {

// Relative luminance of linear sRGB / Rec. 709 primaries.
inline float luminance(const glm::vec3& c) {
  return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z;
}
inline double luminance(const glm::dvec3& c) {
  return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
}

}  // namespace penumbra
