// The light distribution texture (Wallner sec. 3.2) and the luminaire light: its lookup in the
// luminaire's frame, its flux, its emission sampling, and the irradiance the radiosity methods
// take from it.
#include "penumbra/scene/luminaire.h"
#include "penumbra/raytrace/lights.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>

#include <cmath>
#include <numbers>

namespace penumbra {
namespace {

using test::testLuminaire;
using test::testLuminaireCandela;

constexpr double kPi = std::numbers::pi;

// The direction (C, gamma) in a luminaire's frame, in world space.
glm::vec3 frameDirection(const LuminaireLight& l, double c_deg, double g_deg) {
  const double c = glm::radians(c_deg), g = glm::radians(g_deg);
  return glm::normalize(float(std::sin(g) * std::cos(c)) * l.c0 +
                        float(std::sin(g) * std::sin(c)) * l.c90() + float(std::cos(g)) * l.nadir);
}

TEST(Luminaire, FluxOfAnIsotropicDistributionIsFourPiI) {
  LuminaireDistribution t;
  std::string why;
  ASSERT_TRUE(LuminaireDistribution::fromCandela(24, 19, std::vector<double>(24 * 19, 1000.0),
                                                 "iso", t, why))
      << why;
  EXPECT_NEAR(t.flux_lumens / (4.0 * kPi * 1000.0), 1.0, 1e-12);
  EXPECT_DOUBLE_EQ(t.max_candela, 1000.0);
}

TEST(Luminaire, FluxOfTheTableMatchesTheClosedForm) {
  // int I dw of the test distribution: 1000 * 2 pi * 2/5 below, 150 * 2 pi * 1/2 above.
  const double exact = 1000.0 * 2.0 * kPi * 0.4 + 150.0 * 2.0 * kPi * 0.5;
  const LuminaireLight l = testLuminaire();
  // Bilinear between 5-degree samples of a smooth distribution: well under 0.5%.
  EXPECT_NEAR(l.distribution->flux_lumens / exact, 1.0, 5e-3);
  // The radiometric power is the flux over 683 lm/W (Wallner eq. 12).
  const glm::dvec3 power = lightPower(Light(l), Bounds3{});
  EXPECT_NEAR(power.y * kLumensPerWatt / l.distribution->flux_lumens, 1.0, 1e-6);
}

TEST(Luminaire, LookupInTheLuminairesFrameReadsTheGridValues) {
  // A tilted, rotated luminaire: at every grid direction the intensity is the file's value.
  const LuminaireLight l =
      testLuminaire(glm::vec3(0.0f), glm::vec3(0.3f, -1.0f, 0.2f), glm::vec3(0.0f, 0.4f, 1.0f));
  for (int c = 0; c < 36; ++c) {
    for (int g = 0; g <= 36; ++g) {
      const glm::vec3 d = frameDirection(l, 10.0 * c, 5.0 * g);
      const double got = double(luminaireIntensity(l, d).y) * kLumensPerWatt;
      const double want = testLuminaireCandela(10.0 * c, 5.0 * g);
      EXPECT_NEAR(got, want, 2e-3 * 1500.0 + 1e-4 * want) << "C " << 10 * c << " gamma " << 5 * g;
    }
  }
  // Between the grid points: the value lies between the neighbouring samples (bilinear), and
  // close to the smooth function.
  Rng rng(3, 1);
  for (int i = 0; i < 2000; ++i) {
    const double c = 360.0 * rng.uniform(), g = 180.0 * rng.uniform();
    const double got = double(luminaireIntensity(l, frameDirection(l, c, g)).y) * kLumensPerWatt;
    EXPECT_NEAR(got, testLuminaireCandela(c, g), 40.0) << "C " << c << " gamma " << g;
  }
}

TEST(Luminaire, CPlanesTurnAnticlockwiseSeenFromAbove) {
  // A downlight with C0 along +x: C90 is +z's opposite for y up (c90 = c0 x nadir = x x -y = -z).
  const LuminaireLight l = testLuminaire(glm::vec3(0.0f));
  EXPECT_NEAR(glm::length(l.c90() - glm::vec3(0.0f, 0.0f, -1.0f)), 0.0f, 1e-6f);
  // The test distribution is brightest at C0 (1 + 0.5 cos C sin gamma): at gamma 45 the +x
  // side over the -x side is (1 + 0.5 / sqrt 2) / (1 - 0.5 / sqrt 2).
  const float at_c0 = luminaireIntensity(l, glm::normalize(glm::vec3(1.0f, -1.0f, 0.0f))).y;
  const float at_c180 = luminaireIntensity(l, glm::normalize(glm::vec3(-1.0f, -1.0f, 0.0f))).y;
  EXPECT_NEAR(at_c0 / at_c180, (1.0f + 0.5f / std::sqrt(2.0f)) / (1.0f - 0.5f / std::sqrt(2.0f)),
              1e-3f);
}

TEST(Luminaire, IrradianceBelowIsIntensityCosineOverDistanceSquared) {
  // Wallner eq. 15 for a point receiver: E = I(C, gamma) cos(theta) / d^2, at floor points
  // below the luminaire 2.5 m up, at grid directions and between them.
  const LuminaireLight l = testLuminaire(glm::vec3(0.0f, 2.5f, 0.0f));
  const glm::dvec3 up(0.0, 1.0, 0.0);
  for (double x = -3.0; x <= 3.0; x += 0.25) {
    for (double z = -3.0; z <= 3.0; z += 0.5) {
      const glm::dvec3 p(x, 0.0, z);
      const LightSample s = sampleLight(Light(l), p, up, up);
      const glm::dvec3 to_p = p - glm::dvec3(l.position);
      const double d2 = glm::dot(to_p, to_p);
      const double cos_theta = 2.5 / std::sqrt(d2);
      const double intensity = double(luminaireIntensity(l, glm::vec3(to_p / std::sqrt(d2))).y);
      EXPECT_NEAR(s.irradiance.y, intensity * cos_theta / d2, 1e-6 * intensity);
      EXPECT_NEAR(s.distance, std::sqrt(d2), 1e-9);
    }
  }
}

TEST(Luminaire, EmissionSamplingFollowsTheDistribution) {
  // Directions from sampleLuminaireDirection against moments of the distribution computed by
  // quadrature: E[cos gamma] and E[cos C sin gamma] (the C0 side is brighter), within 5 standard
  // errors, and the share going upwards.
  const LuminaireLight l = testLuminaire(glm::vec3(0.0f));
  double q_w = 0.0, q_cg = 0.0, q_cc = 0.0, q_up = 0.0;
  for (int i = 0; i < 720; ++i) {
    for (int j = 0; j < 360; ++j) {
      const double c = (i + 0.5) * 0.5, g = (j + 0.5) * 0.5;
      const double w =
          double(luminaireIntensity(l, frameDirection(l, c, g)).y) * std::sin(glm::radians(g));
      q_w += w;
      q_cg += w * std::cos(glm::radians(g));
      q_cc += w * std::cos(glm::radians(c)) * std::sin(glm::radians(g));
      q_up += g > 90.0 ? w : 0.0;
    }
  }
  Rng rng(11, 4);
  constexpr int kN = 200000;
  double s_cg = 0.0, s_cc = 0.0, s_up = 0.0;
  for (int i = 0; i < kN; ++i) {
    const glm::vec3 d = sampleLuminaireDirection(l, [&] { return rng.uniform(); });
    const double cg = glm::dot(d, l.nadir);
    s_cg += cg;
    s_cc += glm::dot(d, l.c0);
    s_up += cg < 0.0 ? 1.0 : 0.0;
  }
  const double se = 1.0 / std::sqrt(double(kN));  // each quantity is bounded by 1
  EXPECT_NEAR(s_cg / kN, q_cg / q_w, 5.0 * se);
  EXPECT_NEAR(s_cc / kN, q_cc / q_w, 5.0 * se);
  EXPECT_NEAR(s_up / kN, q_up / q_w, 5.0 * se);
  EXPECT_GT(q_cc / q_w, 0.05);  // the test can tell the C0 side from the C180 side
}

TEST(Luminaire, BadDistributionsAreRefused) {
  LuminaireDistribution t;
  std::string why;
  EXPECT_FALSE(LuminaireDistribution::fromCandela(4, 3, std::vector<double>(12, 0.0), "z", t, why));
  EXPECT_NE(why.find("zero"), std::string::npos);
  std::vector<double> v(12, 1.0);
  v[5] = -1.0;
  EXPECT_FALSE(LuminaireDistribution::fromCandela(4, 3, v, "n", t, why));
  v[5] = std::nan("");
  EXPECT_FALSE(LuminaireDistribution::fromCandela(4, 3, v, "n", t, why));
  EXPECT_FALSE(LuminaireDistribution::fromCandela(4, 1, std::vector<double>(4, 1.0), "s", t, why));
  EXPECT_FALSE(LuminaireDistribution::fromCandela(4, 3, std::vector<double>(11, 1.0), "s", t, why));
}

}  // namespace
}  // namespace penumbra
