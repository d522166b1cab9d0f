// Exact direct light from area emitters at calculation points (lighting design, CIE 171:2006
// case 5.3).
//
// A Lambertian emitter triangle t of radiance L_t gives a point x with unit normal n the
// irradiance
//   E_t(x) = pi L_t F_t(x) V_t(x),
// where F_t is the point-to-polygon form factor in closed form (Lambert's formula,
// kernels/form_factor.h; the emitter clipped to x's horizon) and V_t the visible share of the
// emitter weighted by the form-factor kernel cos(theta_x) cos(theta_t) / r^2. V_t is estimated
// with shadow rays, stratified over each triangle (a jittered grid through Heitz's
// square-to-triangle map) and allocated among the triangles in proportion to L_t F_t:
//   V_t = sum_i k_i v_i / sum_i k_i    (k_i the kernel at sample i, v_i its ray's visibility).
// A first pass of kFirstRays rays, and rays to each triangle's corners and edge midpoints (where
// an occluder hiding a sliver shows), decides: all free, V = 1 exactly; all blocked, V = 0;
// otherwise (a penumbra) kPenumbraRays rays more refine the estimate. So an unoccluded emitter
// gives the closed form to rounding, whatever the seed, and a penumbra carries the noise of
// some 4,000 stratified rays instead of the hemisphere gather's.
//
// Emitters with an emission or coverage texture vary over their surface, which the closed form
// cannot follow: they stay with the hemisphere gather (render/illuminance.h).
#pragma once

#include "penumbra/core/rng.h"
#include "penumbra/raytrace/ray_engine.h"
#include "penumbra/scene/scene.h"

#include <glm/vec3.hpp>

#include <cstdint>
#include <vector>

namespace penumbra {

class AreaEmitters {
 public:
  static constexpr int kFirstRays = 16;
  static constexpr int kPenumbraRays = 4096;
  // Above this many emitter triangles the per-point closed form costs more than the gather:
  // the emitters are then left to the hemisphere rays (handles() is false for all).
  static constexpr size_t kMaxTriangles = 16384;

  AreaEmitters(const Scene& scene, const FlatTriangles& flat);

  // Whether triangle `t` (flattenScene numbering) is counted here, so that a gather must leave
  // its emission out.
  bool handles(uint32_t t) const { return t < handled_.size() && handled_[t] != 0; }
  size_t size() const { return emitters_.size(); }

  // The direct irradiance (W m^-2, RGB) at x facing n; shadow rays leave x + lift n. `rays`
  // counts the rays traced.
  glm::dvec3 irradiance(const RayEngine& engine, const glm::dvec3& x, const glm::dvec3& n,
                        double lift, Rng& rng, uint64_t& rays) const;

  // The same emitters' cylindrical illuminance at x (EN 12464-1: the mean vertical irradiance
  // over all horizontal directions about the vertical axis `up`),
  //   E_z = 1/pi * integral L(w) sin(angle(w, up)) dw,
  // by stratified points over each emitter (the kernel has no closed form), shadow rays each.
  glm::dvec3 cylindricalIrradiance(const RayEngine& engine, const glm::dvec3& x,
                                   const glm::dvec3& up, double lift, Rng& rng,
                                   uint64_t& rays) const;

 private:
  struct Emitter {
    glm::dvec3 a, b, c;  // corners, counter-clockwise seen from the front
    glm::dvec3 normal;   // the front's unit normal
    glm::dvec3 radiance;
    double luminance = 0.0;  // of the radiance, for allocating rays
    double area = 0.0;
  };
  std::vector<Emitter> emitters_;
  std::vector<uint8_t> handled_;  // per flat triangle
};

}  // namespace penumbra
