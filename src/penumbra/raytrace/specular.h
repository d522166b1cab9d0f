// Perfect mirrors and smooth glass (Material::scattering): the delta BSDFs of Whitted's ray tracer
// (Whitted 1980) that the path tracer, the whitted method and photon mapping share, so that all
// three follow the same directions with the same weights.
//
// A mirror reflects d about the normal with the weight `specular` (on both faces unless the
// material is one-sided; a one-sided mirror's back is black). Glass is the smooth boundary of a
// closed mesh wound outwards, its inside behind the front face: light arriving at cos theta_i
// reflects with the exact unpolarised Fresnel reflectance F_r(theta_i) (PBRT 4th ed. sec. 9.3,
// kernels/dipole.h) and refracts by Snell's law with 1 - F_r, entirely reflected beyond the
// critical angle. Radiance is not scaled by eta^2 on crossing (PBRT 4th ed. sec. 9.5): light
// leaves the glass before it is seen, so the factors of a path's crossings cancel. `specular`
// filters the refracted light once, as it enters (1 = clear glass).
#pragma once

#include "penumbra/kernels/dipole.h"
#include "penumbra/raytrace/medium_walk.h"
#include "penumbra/scene/material.h"

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

namespace penumbra {

struct SpecularLobe {
  glm::vec3 dir{0.0f};     // unit direction leaving the surface
  glm::vec3 weight{0.0f};  // BSDF x cos / (delta), per channel: what the outgoing radiance carries
  bool transmitted = false;
};

// The (at most two) directions light arriving along `dir` (towards the surface) leaves a mirror or
// glass surface of geometric normal `ng` (front face counter-clockwise) by: reflection first.
struct SpecularLobes {
  SpecularLobe lobe[2];
  int count = 0;
  float fresnel = 1.0f;    // glass: F_r, the reflected share (lobe 0's grey weight)
  glm::vec3 filter{1.0f};  // glass: what the refracted lobe carries besides 1 - F_r
};

inline SpecularLobes specularLobes(const Material& m, const glm::vec3& ng, const glm::vec3& dir) {
  SpecularLobes out;
  const glm::dvec3 d = glm::normalize(glm::dvec3(dir));
  const double cos_front = -glm::dot(glm::dvec3(ng), d);
  const bool from_front = cos_front > 0.0;
  const glm::dvec3 n = from_front ? glm::dvec3(ng) : -glm::dvec3(ng);  // faces the incoming ray
  if (m.scattering == Scattering::kMirror) {
    if (!m.two_sided && !from_front) return out;
    out.lobe[0] = {glm::vec3(reflectDirection(d, n)), m.specular, false};
    out.count = 1;
    return out;
  }
  if (m.scattering != Scattering::kDielectric) return out;
  const double eta = double(m.ior);
  const double n_i = from_front ? 1.0 : eta, n_t = from_front ? eta : 1.0;
  const double f_r = fresnelReflectance(n_i, n_t, std::fabs(cos_front));
  glm::dvec3 t;
  if (f_r >= 1.0 || !refractDirection(d, n, n_i / n_t, t)) {
    out.lobe[0] = {glm::vec3(reflectDirection(d, n)), glm::vec3(1.0f), false};
    out.count = 1;
    return out;
  }
  out.lobe[0] = {glm::vec3(reflectDirection(d, n)), glm::vec3(float(f_r)), false};
  out.filter = from_front ? m.specular : glm::vec3(1.0f);
  out.fresnel = float(f_r);
  out.lobe[1] = {glm::vec3(t), float(1.0 - f_r) * out.filter, true};
  out.count = 2;
  return out;
}

// One lobe chosen at random in proportion to its Fresnel share (the mean of its weight without
// the glass filter), and its weight divided by that probability: what a path (path tracer,
// photons, final gather) follows. `u` is uniform in [0, 1). Returns false when there is none.
inline bool sampleSpecular(const Material& m, const glm::vec3& ng, const glm::vec3& dir, float u,
                           SpecularLobe& chosen) {
  const SpecularLobes lobes = specularLobes(m, ng, dir);
  if (lobes.count == 0) return false;
  if (lobes.count == 1) {
    chosen = lobes.lobe[0];
    return true;
  }
  if (u < lobes.fresnel) {
    chosen = {lobes.lobe[0].dir, glm::vec3(1.0f), false};
  } else {
    chosen = {lobes.lobe[1].dir, lobes.filter, true};
  }
  return true;
}

}  // namespace penumbra
