// Whether a triangle and an axis-aligned box overlap: the separating axis theorem with the 13
// axes of a box and a triangle (the box's three face normals, the triangle's normal and the nine
// cross products of the box's axes with the triangle's edges; Akenine-Moller 2001). Touching
// counts as overlapping.
#pragma once

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <cmath>

namespace penumbra {

inline bool triangleOverlapsBox(const glm::dvec3& centre, const glm::dvec3& half,
                                const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
  const glm::dvec3 v[3] = {a - centre, b - centre, c - centre};
  // The box's face normals: the triangle's bounds against the box.
  for (int i = 0; i < 3; ++i) {
    const double lo = std::min({v[0][i], v[1][i], v[2][i]});
    const double hi = std::max({v[0][i], v[1][i], v[2][i]});
    if (lo > half[i] || hi < -half[i]) return false;
  }
  // The nine edge cross products.
  const glm::dvec3 e[3] = {v[1] - v[0], v[2] - v[1], v[0] - v[2]};
  for (int i = 0; i < 3; ++i) {
    glm::dvec3 axis_i(0.0);
    axis_i[i] = 1.0;
    for (const glm::dvec3& edge : e) {
      const glm::dvec3 axis = glm::cross(axis_i, edge);
      const double p0 = glm::dot(axis, v[0]), p1 = glm::dot(axis, v[1]), p2 = glm::dot(axis, v[2]);
      const double r =
          half.x * std::abs(axis.x) + half.y * std::abs(axis.y) + half.z * std::abs(axis.z);
      if (std::min({p0, p1, p2}) > r || std::max({p0, p1, p2}) < -r) return false;
    }
  }
  // The triangle's plane.
  const glm::dvec3 n = glm::cross(e[0], e[1]);
  const double r = half.x * std::abs(n.x) + half.y * std::abs(n.y) + half.z * std::abs(n.z);
  return std::abs(glm::dot(n, v[0])) <= r;
}

}  // namespace penumbra
