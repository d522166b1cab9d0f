// The formulas of the reference path tracer's walk through translucent media
// (Material::subsurface): the smooth dielectric boundary around the medium and the free flights
// of the random walk inside it. The walk is the physical reference the dipole method
// (subsurface/) is judged against, so it solves the same reduced problem: isotropic scattering
// with sigma_s = sigma_s' (the similarity relation, Wyman, Patterson, Hecht 1989), sigma_t =
// sigma_s' + sigma_a per RGB channel.
#pragma once

#include <glm/exponential.hpp>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace penumbra {

// Uniform direction on the unit sphere, the sample of the isotropic phase function (pdf
// 1 / (4 pi), which cancels against the phase function's value); PBRT 4th ed. sec. A.5.2.
inline glm::dvec3 sampleUniformSphere(double u1, double u2) {
  const double z = 1.0 - 2.0 * u1;
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  const double phi = 2.0 * std::numbers::pi * u2;
  return glm::dvec3(r * std::cos(phi), r * std::sin(phi), z);
}

// Mirror reflection of the direction d (travelling towards the surface) about the unit normal n
// (either side); PBRT 4th ed. sec. 9.3.
inline glm::dvec3 reflectDirection(const glm::dvec3& d, const glm::dvec3& n) {
  return d - 2.0 * glm::dot(d, n) * n;
}

// Snell's law (PBRT 4th ed. sec. 9.3): the unit direction d (travelling towards the surface)
// refracted through a boundary whose unit normal n faces d's side (dot(d, n) < 0), with
// eta_ratio = n_i / n_t (incident over transmitted index). False on total internal reflection.
inline bool refractDirection(const glm::dvec3& d, const glm::dvec3& n, double eta_ratio,
                             glm::dvec3& out) {
  const double cos_i = std::min(1.0, -glm::dot(d, n));
  const double sin2_t = eta_ratio * eta_ratio * std::max(0.0, 1.0 - cos_i * cos_i);
  if (sin2_t >= 1.0) return false;
  const double cos_t = std::sqrt(1.0 - sin2_t);
  out = glm::normalize(eta_ratio * d + (eta_ratio * cos_i - cos_t) * n);
  return true;
}

// One free flight in a homogeneous medium, up to the boundary at distance t_boundary (infinite
// when the ray left the mesh through a crack).
struct FreeFlight {
  double t = 0.0;          // distance travelled
  bool scattered = false;  // true: a scattering event at t; false: the flight reached the boundary
  glm::dvec3 f{1.0};    // per channel: the path contribution of the flight, sigma_s T(t) or T(t_b)
  glm::dvec3 pdf{1.0};  // per channel: its pdf had that channel sampled it
};

// Samples the flight's distance with the exponential pdf of the path's hero channel,
// sigma_t,c exp(-sigma_t,c t) (u_distance, inverted; PBRT 4th ed. sec. 11.2 for the transmittance
// T(t) = exp(-sigma_t t)), and reports, per channel k, the contribution f_k and the pdf p_k
// that sampling by channel k would have had: sigma_s,k T_k(t) and sigma_t,k T_k(t) for a
// scattering event, T_k(t_b) for both when the flight reaches the boundary. The walk weighs the
// whole path by these (SpectralPathWeight). With u_distance a float in [0, 1 - 2^-24], flights
// longer than 16.6 / sigma_t,c are never drawn: a probability of 6e-8, far below any test's
// noise. sigma_t must be positive in every channel (checkSubsurface).
inline FreeFlight sampleFreeFlight(const glm::dvec3& sigma_t, const glm::dvec3& sigma_s,
                                   double t_boundary, int hero, float u_distance) {
  const double t = -std::log(1.0 - double(u_distance)) / sigma_t[hero];
  FreeFlight f;
  if (t < t_boundary) {
    const glm::dvec3 tr = glm::exp(-sigma_t * t);
    f.t = t;
    f.scattered = true;
    f.f = sigma_s * tr;
    f.pdf = sigma_t * tr;
    return f;
  }
  const glm::dvec3 tr = glm::exp(-sigma_t * t_boundary);
  f.t = t_boundary;
  f.f = tr;
  f.pdf = tr;
  return f;
}

// Spectral multiple importance sampling over a whole path (PBRT 4th ed. sec. 14.2.2, chromatic
// media, after Wilkie et al. 2014, hero wavelength spectral sampling): the path's free flights
// are all sampled by one hero channel, chosen uniformly once per path, and the path weighs
//
//   f_c(path) / (1/3 sum_k p_k(path))     per channel c (the one-sample balance heuristic),
//
// where p_k(path) is the product of the flights' pdfs had channel k sampled them (the pdfs of
// every other choice on the path are the same for all channels and cancel). Unbiased for every
// channel however different their coefficients, and at most 3 f_c / p_c: weighting each flight by
// its own channel average instead lets the product of per-flight weights drift over the hundreds
// of events of a walk, with unbounded variance. `ratio` holds p_k(path) up to a common factor
// (normalised to a maximum of 1, so that no product over- or underflows); `update` returns the
// factor by which one more flight of contribution f and pdfs p multiplies the path's weighted
// throughput, or 0 when no channel can have sampled it.
struct SpectralPathWeight {
  glm::dvec3 ratio{1.0};

  glm::dvec3 update(const glm::dvec3& f, const glm::dvec3& pdf) {
    const double before = (ratio.x + ratio.y + ratio.z) / 3.0;
    const glm::dvec3 next = ratio * pdf;
    const double after = (next.x + next.y + next.z) / 3.0;
    const double top = std::max({next.x, next.y, next.z});
    if (!(after > 0.0) || !(top > 0.0)) return glm::dvec3(0.0);
    ratio = next / top;
    return f * (before / after);
  }
};

}  // namespace penumbra
