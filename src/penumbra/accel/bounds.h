// Axis-aligned boxes.
#pragma once

#include <glm/common.hpp>
#include <glm/vec3.hpp>

#include <limits>
#include <span>

namespace penumbra {

struct Bounds3 {
  glm::vec3 lo{std::numeric_limits<float>::infinity()};
  glm::vec3 hi{-std::numeric_limits<float>::infinity()};

  void extend(const glm::vec3& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  void extend(const Bounds3& b) {
    lo = glm::min(lo, b.lo);
    hi = glm::max(hi, b.hi);
  }
  bool empty() const { return !(lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z); }
  glm::vec3 extent() const { return hi - lo; }
  glm::vec3 center() const { return 0.5f * (lo + hi); }
  // Surface area; 0 for an empty box.
  float area() const {
    if (empty()) return 0.0f;
    const glm::vec3 e = hi - lo;
    return 2.0f * (e.x * e.y + e.y * e.z + e.z * e.x);
  }
  // The box around `points`.
  static Bounds3 of(std::span<const glm::vec3> points) {
    Bounds3 b;
    for (const glm::vec3& p : points) b.extend(p);
    return b;
  }
};

}  // namespace penumbra
