// Diffuse subsurface scattering by the dipole approximation: the formulas, for any device (the
// GLSL twin is shaders/sss/dipole.glsl).
//
// Jensen, Marschner, Levoy, Hanrahan, "A Practical Model for Subsurface Light Transport",
// SIGGRAPH 2001 (sec. 2.3-2.4), as Carr, Hall, Hart 2003 (sec. 4, eq. 6-8) use it. A medium of
// reduced scattering coefficient sigma_s' and absorption coefficient sigma_a (per unit length),
// with relative index of refraction eta at its boundary:
//
//   sigma_t' = sigma_s' + sigma_a            reduced extinction
//   alpha'   = sigma_s' / sigma_t'           reduced albedo
//   sigma_tr = sqrt(3 sigma_a sigma_t')      effective transport coefficient
//   D        = 1 / (3 sigma_t')              diffusion constant
//   F_dr     = -1.440 / eta^2 + 0.710 / eta + 0.668 + 0.0636 eta
//                                            diffuse Fresnel reflectance (Egan and Hilgeman's
//                                            fit: light inside hitting the boundary, total
//                                            internal reflection included)
//   A        = (1 + F_dr) / (1 - F_dr)       boundary mismatch
//   z_r      = 1 / sigma_t',  z_v = z_r + 4 A D   depths of the real and the virtual source
//
// The diffuse reflectance at distance r from where light enters (Jensen eq. 4 as a function of
// r, with d_r = sqrt(r^2 + z_r^2), d_v = sqrt(r^2 + z_v^2)):
//
//   R_d(r) = alpha' / (4 pi) [ z_r (sigma_tr d_r + 1) e^(-sigma_tr d_r) / d_r^3
//                            + z_v (sigma_tr d_v + 1) e^(-sigma_tr d_v) / d_v^3 ]
//
// and its integral over the plane (Jensen eq. 5), which follows from d/du (-e^(-s u) / u) =
// (s u + 1) e^(-s u) / u^2 with u = d, r dr = u du:
//
//   R_d = int_0^inf R_d(r) 2 pi r dr = alpha' / 2 (e^(-sigma_tr z_r) + e^(-sigma_tr z_v))
//       = alpha' / 2 (1 + e^(-4/3 A sqrt(3 (1 - alpha')))) e^(-sqrt(3 (1 - alpha'))).
//
// F_t(eta, cos) = 1 - F_r(eta, cos) is the Fresnel transmittance of a smooth boundary for light
// arriving from outside at angle theta (cos = cos theta) and, by reciprocity, for light leaving.
#pragma once

#include <glm/vec3.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace penumbra {

// Unpolarised Fresnel reflectance of a smooth boundary between media of indices n_i (the side
// the light comes from) and n_t, for light at cos_i = cos(theta_i) in [0, 1]; 1 beyond the
// critical angle (total internal reflection). Exact (the average of the s and p reflectances).
inline double fresnelReflectance(double n_i, double n_t, double cos_i) {
  cos_i = std::clamp(cos_i, 0.0, 1.0);
  const double sin_t = n_i / n_t * std::sqrt(std::max(0.0, 1.0 - cos_i * cos_i));
  if (sin_t >= 1.0) return 1.0;
  const double cos_t = std::sqrt(std::max(0.0, 1.0 - sin_t * sin_t));
  const double rs = (n_i * cos_i - n_t * cos_t) / (n_i * cos_i + n_t * cos_t);
  const double rp = (n_t * cos_i - n_i * cos_t) / (n_t * cos_i + n_i * cos_t);
  return 0.5 * (rs * rs + rp * rp);
}

// F_t(eta, w): the share of light arriving from outside (index 1) at cos theta that enters a
// medium of relative index eta; by reciprocity also the share leaving it towards cos theta.
inline double fresnelTransmittance(double eta, double cos_theta) {
  return 1.0 - fresnelReflectance(1.0, eta, cos_theta);
}

// F_dr(eta): the diffuse Fresnel reflectance, Egan and Hilgeman's fit (Jensen et al. 2001,
// sec. 2.4): the hemispherical-cosine average of the reflectance seen from inside a medium of
// relative index eta, total internal reflection included.
inline double diffuseFresnelReflectance(double eta) {
  return -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta;
}

// The share of diffuse light (uniform radiance over the hemisphere) arriving from outside that a
// smooth boundary of relative index eta reflects: 2 int_0^1 F_r(1 -> eta, mu) mu dmu (midpoint
// rule on 512 intervals; the integrand is smooth from outside, to 1e-6).
inline double externalDiffuseFresnelReflectance(double eta) {
  constexpr int kSteps = 512;
  double sum = 0.0;
  for (int i = 0; i < kSteps; ++i) {
    const double mu = (i + 0.5) / kSteps;
    sum += fresnelReflectance(1.0, eta, mu) * mu;
  }
  return 2.0 * sum / kSteps;
}

// The dipole's constants for one colour channel of a medium (lengths in any one unit).
struct DipoleChannel {
  double alpha = 0.0;     // reduced albedo alpha'
  double sigma_tr = 0.0;  // effective transport coefficient
  double z_r = 0.0;       // depth of the real source
  double z_v = 0.0;       // height of the virtual source above the surface (as a distance)

  DipoleChannel() = default;
  DipoleChannel(double sigma_s_prime, double sigma_a, double eta) {
    const double sigma_t = sigma_s_prime + sigma_a;
    alpha = sigma_t > 0.0 ? sigma_s_prime / sigma_t : 0.0;
    sigma_tr = std::sqrt(3.0 * sigma_a * sigma_t);
    const double f_dr = diffuseFresnelReflectance(eta);
    const double a = (1.0 + f_dr) / (1.0 - f_dr);
    z_r = 1.0 / sigma_t;
    z_v = z_r * (1.0 + 4.0 / 3.0 * a);
  }

  // R_d(r), per unit area (length^-2).
  double reflectance(double r) const {
    const double r2 = r * r;
    const double d_r = std::sqrt(r2 + z_r * z_r), d_v = std::sqrt(r2 + z_v * z_v);
    const double real =
        z_r * (sigma_tr * d_r + 1.0) * std::exp(-sigma_tr * d_r) / (d_r * d_r * d_r);
    const double virt =
        z_v * (sigma_tr * d_v + 1.0) * std::exp(-sigma_tr * d_v) / (d_v * d_v * d_v);
    return alpha / (4.0 * std::numbers::pi) * (real + virt);
  }

  // The part of R_d(r) 2 pi r dr between 0 and r: alpha'/2 [e^(-s z_r) - z_r e^(-s d_r) / d_r +
  // e^(-s z_v) - z_v e^(-s d_v) / d_v] (the same antiderivative as the total).
  double reflectanceWithin(double r) const {
    const double d_r = std::sqrt(r * r + z_r * z_r), d_v = std::sqrt(r * r + z_v * z_v);
    return 0.5 * alpha *
           (std::exp(-sigma_tr * z_r) - z_r * std::exp(-sigma_tr * d_r) / d_r +
            std::exp(-sigma_tr * z_v) - z_v * std::exp(-sigma_tr * d_v) / d_v);
  }

  // The total diffuse reflectance R_d = int R_d(r) 2 pi r dr (dimensionless).
  double totalReflectance() const {
    return 0.5 * alpha * (std::exp(-sigma_tr * z_r) + std::exp(-sigma_tr * z_v));
  }
};

// Jensen et al.'s closed form of the total diffuse reflectance from the reduced albedo alone.
inline double totalDiffuseReflectance(double alpha_prime, double eta) {
  const double f_dr = diffuseFresnelReflectance(eta);
  const double a = (1.0 + f_dr) / (1.0 - f_dr);
  const double s = std::sqrt(3.0 * (1.0 - alpha_prime));
  return 0.5 * alpha_prime * (1.0 + std::exp(-4.0 / 3.0 * a * s)) * std::exp(-s);
}

// The three channels of a medium.
struct Dipole {
  DipoleChannel channel[3];

  Dipole() = default;
  Dipole(const glm::dvec3& sigma_s_prime, const glm::dvec3& sigma_a, double eta) {
    for (int c = 0; c < 3; ++c) channel[c] = DipoleChannel(sigma_s_prime[c], sigma_a[c], eta);
  }
  glm::dvec3 reflectance(double r) const {
    return {channel[0].reflectance(r), channel[1].reflectance(r), channel[2].reflectance(r)};
  }
  glm::dvec3 totalReflectance() const {
    return {channel[0].totalReflectance(), channel[1].totalReflectance(),
            channel[2].totalReflectance()};
  }
  // The distance beyond which R_d(r) 2 pi r dr holds less than `fraction` of the total, in the
  // slowest-decaying channel (bisection on reflectanceWithin).
  double radiusHolding(double fraction) const {
    double radius = 0.0;
    for (const DipoleChannel& ch : channel) {
      const double total = ch.totalReflectance();
      if (!(total > 0.0)) continue;
      double lo = 0.0, hi = ch.z_v;
      while (ch.reflectanceWithin(hi) < (1.0 - fraction) * total && hi < 1e30) hi *= 2.0;
      for (int i = 0; i < 100; ++i) {
        const double mid = 0.5 * (lo + hi);
        (ch.reflectanceWithin(mid) < (1.0 - fraction) * total ? lo : hi) = mid;
      }
      radius = std::max(radius, hi);
    }
    return radius;
  }
};

}  // namespace penumbra
