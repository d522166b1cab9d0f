// The dipole's formulas (kernels/dipole.h) against independent numerical integration: the
// profile R_d(r) integrates to the closed-form total diffuse reflectance, and Egan and
// Hilgeman's fit of the diffuse Fresnel reflectance matches the cosine-weighted hemispherical
// average of the exact Fresnel reflectance seen from inside.
#include "penumbra/kernels/dipole.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace penumbra {
namespace {

// int_0^inf R_d(r) 2 pi r dr by composite Simpson in u = log(r) over 24 decades around the
// source depth (the profile is smooth in log r, from its plateau at r << z_r to its exponential
// tail).
double integrateProfile(const DipoleChannel& ch) {
  const double lo = std::log(ch.z_r * 1e-8), hi = std::log(ch.z_r * 1e8 + 60.0 / ch.sigma_tr);
  const int n = 20000;  // even
  const double h = (hi - lo) / n;
  double sum = 0.0;
  for (int i = 0; i <= n; ++i) {
    const double r = std::exp(lo + h * i);
    const double f = ch.reflectance(r) * 2.0 * std::numbers::pi * r * r;  // dr = r du
    sum += f * (i == 0 || i == n ? 1.0 : (i % 2 ? 4.0 : 2.0));
  }
  return sum * h / 3.0;
}

TEST(Dipole, ProfileIntegratesToTheClosedFormForEveryAlbedo) {
  for (double eta : {1.0, 1.3, 1.5}) {
    for (double alpha : {0.01, 0.1, 0.3, 0.5, 0.7, 0.9, 0.99, 0.999}) {
      // sigma_t' = 1.7 per unit length; any scale gives the same total.
      const double sigma_t = 1.7;
      const DipoleChannel ch(alpha * sigma_t, (1.0 - alpha) * sigma_t, eta);
      const double closed = totalDiffuseReflectance(alpha, eta);
      EXPECT_NEAR(ch.totalReflectance() / closed, 1.0, 1e-12) << "alpha' " << alpha;
      EXPECT_NEAR(integrateProfile(ch) / closed, 1.0, 0.005)
          << "alpha' " << alpha << " eta " << eta;
      // The partial integral tends to the total.
      EXPECT_NEAR(ch.reflectanceWithin(1e6) / closed, 1.0, 1e-9);
      EXPECT_NEAR(ch.reflectanceWithin(0.0), 0.0, 1e-15);
    }
  }
}

TEST(Dipole, TotalReflectanceFollowsJensensTable) {
  // Jensen et al. 2001 measured marble (mm^-1, red channel: sigma_s' 2.19, sigma_a 0.0021): a
  // bright, highly scattering material.
  const Dipole marble(glm::dvec3(2.19, 2.62, 3.00), glm::dvec3(0.0021, 0.0041, 0.0071), 1.3);
  const glm::dvec3 rd = marble.totalReflectance();
  EXPECT_GT(rd.x, 0.8);
  EXPECT_GT(rd.x, rd.z);  // the blue channel absorbs more
  // Ketchup's green and blue absorb strongly.
  const Dipole ketchup(glm::dvec3(0.18, 0.07, 0.03), glm::dvec3(0.061, 0.97, 1.45), 1.3);
  EXPECT_LT(ketchup.totalReflectance().y, 0.05);
  // More absorption, less reflectance; no scattering, none.
  EXPECT_LT(totalDiffuseReflectance(0.5, 1.3), totalDiffuseReflectance(0.9, 1.3));
  EXPECT_EQ(totalDiffuseReflectance(0.0, 1.3), 0.0);
  // Without absorption everything comes back out.
  EXPECT_NEAR(totalDiffuseReflectance(1.0, 1.3), 1.0, 1e-15);
}

TEST(Dipole, RadiusHoldsTheRequestedShare) {
  const Dipole skin(glm::dvec3(0.74, 0.88, 1.01), glm::dvec3(0.032, 0.17, 0.48), 1.3);
  const double r = skin.radiusHolding(0.01);
  // The red channel decays slowest: 99% of its reflectance lies within r.
  const DipoleChannel& red = skin.channel[0];
  EXPECT_NEAR(red.reflectanceWithin(r) / red.totalReflectance(), 0.99, 1e-6);
  for (const DipoleChannel& ch : skin.channel) {
    EXPECT_GE(ch.reflectanceWithin(r) / ch.totalReflectance(), 0.99 - 1e-9);
  }
}

// 2 int_0^{pi/2} F_r(eta -> 1, theta) cos(theta) sin(theta) dtheta: light inside the medium
// (index eta) reaching the boundary with a cosine-weighted distribution.
double internalDiffuseReflectance(double eta) {
  const int n = 200000;
  double sum = 0.0;
  for (int i = 0; i < n; ++i) {
    const double mu = (i + 0.5) / n;  // cos theta; 2 mu d mu
    sum += fresnelReflectance(eta, 1.0, mu) * 2.0 * mu / n;
  }
  return sum;
}

TEST(Dipole, DiffuseFresnelFitMatchesTheIntegratedFresnelTerm) {
  for (double eta : {1.2, 1.3, 1.4, 1.5, 1.6, 1.8, 2.0}) {
    const double exact = internalDiffuseReflectance(eta);
    EXPECT_NEAR(diffuseFresnelReflectance(eta) / exact, 1.0, 0.01) << "eta " << eta;
  }
}

TEST(Dipole, FresnelTermsAreExactAtKnownAngles) {
  // Normal incidence: ((eta - 1) / (eta + 1))^2.
  EXPECT_NEAR(fresnelReflectance(1.0, 1.5, 1.0), 0.04, 1e-12);
  EXPECT_NEAR(fresnelTransmittance(1.5, 1.0), 0.96, 1e-12);
  // Grazing: everything is reflected.
  EXPECT_NEAR(fresnelTransmittance(1.5, 0.0), 0.0, 1e-12);
  // Brewster's angle: tan(theta_B) = eta, the p reflectance vanishes, R = rs^2 / 2.
  const double theta_b = std::atan(1.5);
  const double cos_i = std::cos(theta_b), cos_t = std::cos(std::asin(std::sin(theta_b) / 1.5));
  const double rs = (cos_i - 1.5 * cos_t) / (cos_i + 1.5 * cos_t);
  EXPECT_NEAR(fresnelReflectance(1.0, 1.5, cos_i), 0.5 * rs * rs, 1e-12);
  // From inside, beyond the critical angle asin(1 / 1.5): total internal reflection.
  EXPECT_EQ(fresnelReflectance(1.5, 1.0, std::cos(0.75)), 1.0);
  EXPECT_LT(fresnelReflectance(1.5, 1.0, std::cos(0.7)), 1.0);
  // Reciprocity: the transmittances of the two directions of one path agree.
  const double ci = 0.6, si = std::sqrt(1 - ci * ci), ct = std::sqrt(1 - si * si / 2.25);
  EXPECT_NEAR(1.0 - fresnelReflectance(1.0, 1.5, ci), 1.0 - fresnelReflectance(1.5, 1.0, ct),
              1e-12);
}

}  // namespace
}  // namespace penumbra
