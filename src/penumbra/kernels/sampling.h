// Sampling formulas shared by the Monte Carlo methods (pbrt-v4, ch. 2 and A.5).
#pragma once

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cmath>
#include <cstdint>

namespace penumbra {

inline constexpr float kPi = 3.14159265358979323846f;
inline constexpr float kInvPi = 0.31830988618379067154f;

// An orthonormal basis around unit n (Duff et al., "Building an Orthonormal Basis, Revisited",
// JCGT 6(1), 2017).
struct Frame {
  glm::vec3 t, b, n;

  static Frame fromNormal(const glm::vec3& n) {
    const float sign = std::copysign(1.0f, n.z);
    const float a = -1.0f / (sign + n.z);
    const float b = n.x * n.y * a;
    return Frame{glm::vec3(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x),
                 glm::vec3(b, sign + n.y * n.y * a, -n.y), n};
  }
  glm::vec3 toWorld(const glm::vec3& v) const { return v.x * t + v.y * b + v.z * n; }
};

// Cosine-weighted direction on the hemisphere around +z (Malley's method over a concentric
// disc map, Shirley and Chiu 1997); pdf = cos(theta) / pi.
inline glm::vec3 sampleCosineHemisphere(float u1, float u2) {
  const float ox = 2.0f * u1 - 1.0f, oy = 2.0f * u2 - 1.0f;
  float r = 0.0f, phi = 0.0f;
  if (ox != 0.0f || oy != 0.0f) {
    if (std::fabs(ox) > std::fabs(oy)) {
      r = ox;
      phi = 0.25f * kPi * (oy / ox);
    } else {
      r = oy;
      phi = 0.5f * kPi - 0.25f * kPi * (ox / oy);
    }
  }
  const float x = r * std::cos(phi), y = r * std::sin(phi);
  return glm::vec3(x, y, std::sqrt(std::fmax(0.0f, 1.0f - x * x - y * y)));
}

// Uniform point on a triangle as barycentrics (b1, b2) of vertices 1 and 2 (Heitz, "A
// Low-Distortion Map Between Triangle and Square", 2019).
inline glm::vec2 sampleTriangleBarycentrics(float u1, float u2) {
  float b0, b1;
  if (u1 < u2) {
    b0 = u1 / 2.0f;
    b1 = u2 - b0;
  } else {
    b1 = u2 / 2.0f;
    b0 = u1 - b1;
  }
  return glm::vec2(b1, 1.0f - b0 - b1);
}

// A uniform point of triangle (a, b, c) for (u, v) in the unit square (Heitz's map).
inline glm::dvec3 pointOnTriangle(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c,
                                  float u, float v) {
  const glm::vec2 w = sampleTriangleBarycentrics(u, v);
  return a + double(w.x) * (b - a) + double(w.y) * (c - a);
}

// Cell i of a jittered side x side grid over the unit square, (u1, u2) the point in the cell:
// one sample a cell. Across a straight edge (a shadow's) its error falls as N^-3/4 through
// Heitz's map, where a randomly shifted Hammersley set fell as N^-1/2.
inline glm::vec2 jitteredCell(uint32_t i, uint32_t side, float u1, float u2) {
  const float u = (float(i % side) + u1) / float(side);
  const float v = (float(i / side) + u2) / float(side);
  return {std::fmin(u, 0x1.fffffep-1f), std::fmin(v, 0x1.fffffep-1f)};
}

// Systematic sampling of `count` samples over weights laid end to end (total `total`, `shift` in
// [0, 1) shared by all): the samples of the weight spanning [before, after), the floor or the
// ceiling of its share, and the side of the jittered square they are laid out on (side^2 >= it).
struct SystematicShare {
  uint32_t samples = 0, side = 0;
};
inline SystematicShare systematicShare(double before, double after, double total, int count,
                                       double shift) {
  const double lo = std::floor(before / total * count + shift);
  const double hi = std::floor(after / total * count + shift);
  const uint32_t m = uint32_t(std::fmax(0.0, hi - lo));
  return {m, uint32_t(std::ceil(std::sqrt(double(m))))};
}

// Twice the area of the fan triangle (c[0], c[k], c[k + 1]) of a convex polygon.
inline double fanTriangleArea2(const glm::dvec3* c, int k) {
  return glm::length(glm::cross(c[k] - c[0], c[k + 1] - c[0]));
}

// A point of convex polygon c (count >= 3 corners, fanned from c[0]) uniform by area: `at` in
// [0, 2 * area) picks the fan triangle (the last one if rounding runs past), (u, v) the point in
// it (Heitz's map).
inline glm::dvec3 pointOnFan(const glm::dvec3* c, int count, double at, float u, float v) {
  int k = 1;
  for (; k + 2 < count; ++k) {
    const double w = fanTriangleArea2(c, k);
    if (at < w) break;
    at -= w;
  }
  const glm::vec2 b = sampleTriangleBarycentrics(u, v);
  return c[0] + double(b.x) * (c[k] - c[0]) + double(b.y) * (c[k + 1] - c[0]);
}

// Veach's power heuristic (beta = 2) for two sampling strategies.
inline float powerHeuristic(float pdf_a, float pdf_b) {
  const float a = pdf_a * pdf_a, b = pdf_b * pdf_b;
  return a + b > 0.0f ? a / (a + b) : 0.0f;
}

}  // namespace penumbra
