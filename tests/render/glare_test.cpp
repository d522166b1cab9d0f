// Discomfort glare (render/glare_index.h, render/glare.h) against what can be worked out by hand:
// Guth's table against Levin's independent fit to the same data, the projected luminous areas
// and CIE 146's small-source form in closed form, UGR of one source computed from CIE 117 eq. 4.1
// directly, a luminaire's luminance as its file's intensity over its projected opening, and an
// emitting panel's solid angle against the closed form for a rectangle.
#include "penumbra/render/glare.h"
#include "penumbra/io/luminaire_io.h"
#include "penumbra/io/photometry.h"
#include "penumbra/render/glare_index.h"
#include "support/test_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

namespace penumbra {
namespace {

using test::addQuad;

constexpr double kDegree = std::numbers::pi / 180.0;

// Every filled cell of CIE 117 Table 4.1 as transcribed against Levin's fit (a different source
// for the same index): a slipped digit shows as a cell far off the fit.
TEST(GuthIndex, TableAgreesWithLevinsFit) {
  std::vector<double> errors;
  for (int t = 0; t <= 30; ++t) {
    for (int h = 0; h <= 19; ++h) {
      const double tr = t / 10.0, hr = h / 10.0;
      const double p = guthPositionIndex(hr, tr);
      if (std::isnan(p)) {
        // Blank only high above the line of sight near it.
        EXPECT_GE(h, 18) << tr << " " << hr;
        EXPECT_LE(t, 8) << tr << " " << hr;
        continue;
      }
      const double tau = std::atan2(tr, hr) / kDegree;
      const double sigma = std::acos(1.0 / std::sqrt(1.0 + tr * tr + hr * hr)) / kDegree;
      const double levin = guthPositionIndexLevin(tau, sigma);
      errors.push_back(std::abs(p / levin - 1.0));
      EXPECT_LT(std::abs(p / levin - 1.0), 0.112) << "T/R " << tr << ", H/R " << hr;
    }
  }
  EXPECT_EQ(errors.size(), 607u);
  std::nth_element(errors.begin(), errors.begin() + ptrdiff_t(errors.size() / 2), errors.end());
  EXPECT_LT(errors[errors.size() / 2], 0.06) << "median difference from the fit";
  EXPECT_DOUBLE_EQ(guthPositionIndex(0.0, 0.0), 1.0);  // on the line of sight
  // Bilinear between cells (T/R 1.0-1.1, H/R 0.5-0.6: 3.91 4.40 / 4.20 4.70).
  EXPECT_NEAR(guthPositionIndex(0.55, 1.05), 0.25 * (3.91 + 4.40 + 4.20 + 4.70), 1e-12);
  EXPECT_DOUBLE_EQ(guthPositionIndex(0.5, -1.0), guthPositionIndex(0.5, 1.0));
  EXPECT_TRUE(std::isnan(guthPositionIndex(1.95, 0.0)));  // next to a blank cell
  EXPECT_TRUE(std::isnan(guthPositionIndex(2.0, 1.5)));   // above the field of view
  EXPECT_TRUE(std::isnan(guthPositionIndex(0.5, 3.1)));   // beside it
}

TEST(GlareTerms, ProjectedLuminousAreasAreTheClosedForms) {
  const LuminousOpening box{1.2, 0.3, 0.1, false};
  EXPECT_NEAR(projectedLuminousArea(box, 0, 0, 1), 0.36, 1e-12);   // from straight below
  EXPECT_NEAR(projectedLuminousArea(box, 1, 0, 0), 0.03, 1e-12);   // the end: w h
  EXPECT_NEAR(projectedLuminousArea(box, 0, -1, 0), 0.12, 1e-12);  // the side: l h
  const double c = std::cos(60 * kDegree), s = std::sin(60 * kDegree);
  EXPECT_NEAR(projectedLuminousArea(box, 0, s, c), 0.36 * c + 0.12 * s, 1e-12);
  const LuminousOpening disc{0.2, 0.2, 0.05, true};
  EXPECT_NEAR(projectedLuminousArea(disc, s, 0, c), std::numbers::pi * 0.01 * c + 0.2 * 0.05 * s,
              1e-12);
  EXPECT_NEAR(projectedLuminousArea(disc, 0, 0, -1), 0.0, 1e-12);  // from above: nothing lit
}

// CIE 146:2002: below 0.005 m^2, L^2 omega = 200 I^2 / r^2; above, I^2 / (A r^2); continuous.
TEST(GlareTerms, SmallSourcesTakeCie146sForm) {
  const double r = 4.0, t = 1.0, h = 2.0, i = 800.0;
  const double p = guthPositionIndex(h / r, t / r), d2 = r * r + t * t + h * h;
  for (const double area : {0.0, 0.001, 0.005}) {
    const GlareTerm g = glareTermOfIntensity(r, t, h, i, area);
    ASSERT_TRUE(g.counted);
    EXPECT_NEAR(g.term, 200.0 * i * i / (d2 * p * p), 1e-9 * g.term) << area;
  }
  const GlareTerm big = glareTermOfIntensity(r, t, h, i, 0.04);
  EXPECT_NEAR(big.luminance, i / 0.04, 1e-9);
  EXPECT_NEAR(big.solid_angle, 0.04 / d2, 1e-15);
  EXPECT_NEAR(big.term, i * i / (0.04 * d2 * p * p), 1e-9 * big.term);
  // Behind the eye, below the line of sight: not counted.
  EXPECT_FALSE(glareTermOfIntensity(-r, t, h, i, 0.04).counted);
  EXPECT_FALSE(glareTermOfIntensity(r, t, -0.1, i, 0.04).counted);
}

struct GlareScene {
  Scene scene;
  FlatTriangles flat;
  RayEngine engine;
  void build() {
    flat = flattenScene(scene);
    engine = RayEngine::build(flat.positions, flat.triangles);
  }
};

// A far floor, so that the engine has geometry, and the sources given.
GlareScene floorScene() {
  GlareScene s;
  s.scene.source = "test:glare";
  s.scene.materials = {{"floor", glm::vec3(0.2f), glm::vec3(0.0f)}};
  Mesh m;
  addQuad(m, {-50, -5, -50}, {0, 0, 100}, {100, 0, 0}, 0);
  s.scene.meshes.push_back(m);
  return s;
}

// One point light of 1000 cd 2 m ahead and 1 m above the eye (H/R = 0.5 on the line of sight:
// p = 2.86 in the table), L_b 10 cd/m^2: UGR = 8 log10(0.25 / 10 x 200 I^2 / (r^2 p^2)).
TEST(Glare, OnePointSourceIsCie117ByHand) {
  GlareScene s = floorScene();
  const float w = float(1000.0 / kLumensPerWatt);
  s.scene.lights.push_back(PointLight{{0.0f, 1.0f, 2.0f}, glm::vec3(w)});
  s.build();
  const GlareResult g =
      glareAt(s.scene, s.engine, s.flat, glm::dvec3(0.0), glm::dvec3(0, 0, 1), 10.0, 1);
  ASSERT_EQ(g.sources.size(), 1u);
  const double expected = 8.0 * std::log10(0.25 / 10.0 * 200.0 * 1e6 / (5.0 * 2.86 * 2.86));
  EXPECT_NEAR(g.ugr, expected, 1e-4);
  EXPECT_NEAR(g.sources[0].term.position_index, 2.86, 1e-9);
  // Looking away, or with a wall between: nothing glares.
  EXPECT_TRUE(std::isnan(
      glareAt(s.scene, s.engine, s.flat, glm::dvec3(0.0), glm::dvec3(0, 0, -1), 10.0, 1).ugr));
  Mesh wall;
  addQuad(wall, {-2, -2, 1}, {4, 0, 0}, {0, 4, 0}, 0);
  s.scene.meshes.push_back(wall);
  s.build();
  EXPECT_TRUE(std::isnan(
      glareAt(s.scene, s.engine, s.flat, glm::dvec3(0.0), glm::dvec3(0, 0, 1), 10.0, 1).ugr));
}

// A real downlight's luminance towards the eye is its file's intensity over the projected area
// of the round opening the file states (0.132 m across).
TEST(Glare, LuminaireLuminanceIsItsIntensityOverItsProjectedOpening) {
  const std::string file =
      std::string(PENUMBRA_SOURCE_DIR) + "/tests/data/photometry/ledvance_biolux_dn150.ldt";
  Expected<Photometry> p = readPhotometry(file);
  ASSERT_TRUE(p) << p.error().message;
  auto ldt = luminaireDistribution(*p);
  ASSERT_TRUE(ldt);
  GlareScene s = floorScene();
  LuminaireLight l;
  l.position = glm::vec3(0.0f, 2.0f, 2.0f);  // 45 degrees from the nadir towards the eye
  l.distribution = *ldt;
  l.scale = glm::vec3(float((*ldt)->max_candela / kLumensPerWatt));
  s.scene.lights.push_back(l);
  s.build();
  const GlareResult g =
      glareAt(s.scene, s.engine, s.flat, glm::dvec3(0.0), glm::dvec3(0, 0, 1), 10.0, 1);
  ASSERT_EQ(g.sources.size(), 1u);
  const double area = std::numbers::pi / 4.0 * 0.132 * 0.132 * std::cos(45 * kDegree);
  // Towards the eye: C = 90 (the eye at -z, C90 along c0 x nadir = -z).
  const double candela = p->intensity(90.0, 45.0);
  EXPECT_NEAR(g.sources[0].term.luminance, candela / area, 0.002 * candela / area);
  EXPECT_NEAR(g.sources[0].term.solid_angle, area / 8.0, 1e-9);
}

// An emitting panel 1 m x 0.5 m, 2 m above the eye and 3-4 m ahead: its solid angle is the
// difference of corner rectangles' (closed form), its luminance 683 x its radiance's luminance.
TEST(Glare, EmittingSurfacesGiveTheirLuminanceAndSolidAngle) {
  GlareScene s = floorScene();
  s.scene.materials.push_back({"panel", glm::vec3(0.0f), glm::vec3(2.0f)});
  Mesh m;
  addQuad(m, {-0.5f, 2.0f, 3.0f}, {1.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 1.0f}, 1);  // facing down
  s.scene.meshes.push_back(m);
  s.build();
  const GlareResult g =
      glareAt(s.scene, s.engine, s.flat, glm::dvec3(0.0), glm::dvec3(0, 0, 1), 10.0, 7);
  ASSERT_EQ(g.sources.size(), 1u);
  // The solid angle of a rectangle [0, a] x [0, b] at height h over one of its corners.
  auto corner = [](double a, double b, double h) {
    return std::atan(a * b / (h * std::sqrt(a * a + b * b + h * h)));
  };
  const double omega = 2.0 * (corner(0.5, 4.0, 2.0) - corner(0.5, 3.0, 2.0));
  EXPECT_NEAR(g.sources[0].term.solid_angle, omega, 0.01 * omega);
  EXPECT_NEAR(g.sources[0].term.luminance, 2.0 * kLumensPerWatt, 1e-6);
  // The effective index lies within the panel's range of indices.
  const double p_near = guthPositionIndex(2.0 / 3.0, 0.0), p_far = guthPositionIndex(0.5, 0.125);
  EXPECT_GT(g.sources[0].term.position_index, std::min(p_near, p_far));
  EXPECT_LT(g.sources[0].term.position_index, std::max(p_near, p_far) * 1.02);
}

}  // namespace
}  // namespace penumbra
