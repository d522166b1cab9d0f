// Where the shadow rays of a shooter point start, in scenes with cut-outs. The radiosity
// methods test visibility between regular grids: receivers at their texels' centres, shooter
// points at their elements' or clusters' centres. A cut-out's mask is a regular grid too (a
// lattice, a fence, leaves on a texel grid), and where the grids line up the rays sample the
// mask on a lattice of their own: they can land exactly on the mask's alpha = cutoff contours
// (counted as covered: glTF's alpha >= cutoff) or beat against its period, and a half-open
// lattice then casted two-thirds of a shadow (tests/raytrace/gpu_cutouts_test.cpp). Each pair's
// shadow ray therefore leaves the shooter point from a spot of the point's own disc (eq. 2's
// disc of area A, within half its radius), chosen by a hash of the pair: the form factors keep
// the point's centre, only visibility moves, and opaque scenes keep their centred rays.
#pragma once

#include "penumbra/core/rng.h"

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <cmath>
#include <cstdint>
#include <numbers>

namespace penumbra {

// An offset in the plane of `normal` (unit), within half the radius of a disc of area `area`,
// from the hash `key`: uniform over that smaller disc.
inline glm::dvec3 cutoutJitter(const glm::dvec3& normal, double area, uint64_t key) {
  const uint32_t h1 = mixBits32(uint32_t(key) ^ mixBits32(uint32_t(key >> 32) + 0x68e31da4u));
  const uint32_t h2 = mixBits32(h1 + 0x9e3779b9u);
  const double u1 = double(h1 >> 8) * 0x1p-24, u2 = double(h2 >> 8) * 0x1p-24;
  const double radius = 0.5 * std::sqrt(area / std::numbers::pi) * std::sqrt(u1);
  const double phi = 2.0 * std::numbers::pi * u2;
  // A frame around the normal (Duff et al. 2017).
  const double sign = std::copysign(1.0, normal.z);
  const double a = -1.0 / (sign + normal.z), b = normal.x * normal.y * a;
  const glm::dvec3 t(1.0 + sign * normal.x * normal.x * a, sign * b, -sign * normal.x);
  const glm::dvec3 s(b, sign + normal.y * normal.y * a, -normal.y);
  return radius * (std::cos(phi) * t + std::sin(phi) * s);
}

}  // namespace penumbra
