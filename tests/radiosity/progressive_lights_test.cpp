// Progressive radiosity with point, spot and directional lights (they shoot first, with Ray
// Engine shadows) and two-sided surfaces (elements on both sides): the inverse-square cosine
// law on a large floor, the glTF spot fall-off, a directional light's E cos, and a closed room
// whose wall is wound outwards losing nothing.
#include "penumbra/io/luminaire_io.h"
#include "penumbra/radiosity/progressive.h"
#include "penumbra/raytrace/lights.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>

#include <cmath>
#include <numbers>

namespace penumbra {
namespace {

using test::addQuad;

Scene floorScene(const Light& light) {
  Scene s;
  s.source = "test:floor";
  s.materials = {{"floor", glm::vec3(0.5f), glm::vec3(0.0f)}};
  Mesh m;
  m.name = "floor";
  addQuad(m, {-10, 0, -10}, {0, 0, 20}, {20, 0, 0}, 0);  // facing +y
  s.meshes.push_back(m);
  s.lights.push_back(light);
  return s;
}

// The irradiance each front element of the floor got from the lights' shot (B = rho E), against
// `expect(p)`: the worst relative error over elements with an expected value above `floor_e`.
// A shot is closed when every probe ray finds a face with elements (then the power arriving is
// scaled to the power shot): a spot whose cone lands on the floor is, a point light or a slanted
// directional light over a floor is not.
template <typename Expect>
double worstIrradianceError(const Scene& scene, Expect&& expect, double floor_e, size_t* count,
                            bool closed = false, double density = 2.0) {
  ProgressiveOptions o;
  o.atlas.texel_density = density;
  Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(scene, o);
  EXPECT_TRUE(pr.ok()) << pr.error().describe();
  EXPECT_EQ(pr->selectShooter(), ProgressiveRadiosity::kLights);
  const ProgressiveIteration it = pr->step();
  EXPECT_EQ(it.shooter, ProgressiveRadiosity::kLights);
  EXPECT_EQ(it.closed, closed);
  double worst = 0.0;
  *count = 0;
  for (size_t e = 0; e < pr->elementCount(); ++e) {
    if (pr->atlas().faces[pr->atlas().element_face[e]].back) {
      EXPECT_EQ(pr->radiosity(e), glm::dvec3(0.0));  // the floor's underside sees no light
      continue;
    }
    const double want = expect(pr->elementPosition(e));
    const double got = pr->radiosity(e).x / 0.5;
    if (want < floor_e) {
      EXPECT_LE(got, floor_e * 1.01);
      continue;
    }
    worst = std::max(worst, std::abs(got / want - 1.0));
    ++*count;
  }
  // The books: the light's power is emitted; what did not reach the floor escaped.
  const EnergyBalance& b = pr->balance();
  const glm::dvec3 rhs = b.absorbed + pr->unshotPower() + b.escaped;
  EXPECT_NEAR(rhs.x, b.emitted.x, 1e-9 * b.emitted.x);
  return worst;
}

TEST(ProgressiveLights, PointLightFollowsTheInverseSquareCosineLaw) {
  const double h = 2.0, intensity = 50.0;
  const Scene scene = floorScene(PointLight{glm::vec3(0.3f, float(h), -0.7f), glm::vec3(50.0f)});
  size_t count = 0;
  const double worst = worstIrradianceError(
      scene,
      [&](const glm::dvec3& p) {
        const glm::dvec3 d = glm::dvec3(0.3, h, -0.7) - p;
        const double r = glm::length(d);
        return intensity * h / (r * r * r);  // I cos / r^2, cos = h / r
      },
      0.0, &count);
  std::printf("point light over a 20 m floor: %zu elements, worst irradiance error %.2e\n", count,
              worst);
  EXPECT_GT(count, 1000u);
  EXPECT_LE(worst, 0.005);  // the bar
}

TEST(ProgressiveLights, SpotLightFollowsTheGltfFallOff) {
  SpotLight spot;
  spot.position = glm::vec3(0.0f, 3.0f, 0.0f);
  spot.direction = glm::vec3(0.0f, -1.0f, 0.0f);
  spot.intensity = glm::vec3(80.0f);
  spot.inner_angle = 0.3f;
  spot.outer_angle = 0.6f;
  const Scene scene = floorScene(spot);
  size_t count = 0;
  const double worst = worstIrradianceError(
      scene,
      [&](const glm::dvec3& p) {
        const glm::dvec3 d = glm::dvec3(0.0, 3.0, 0.0) - p;
        const double r = glm::length(d);
        const double cos_a = 3.0 / r;  // from the axis (straight down)
        const double s =
            std::clamp((cos_a - std::cos(0.6)) / (std::cos(0.3) - std::cos(0.6)), 0.0, 1.0);
        return 80.0 * s * s * cos_a / (r * r);
      },
      1e-3, &count, true, 6.0);
  std::printf("spot light: %zu elements inside the cone, worst irradiance error %.2e\n", count,
              worst);
  EXPECT_GT(count, 200u);
  EXPECT_LE(worst, 0.005);
  // Its power: 2 pi I times the fall-off's integral over the cone, against a fine quadrature.
  double integral = 0.0;
  constexpr int kSteps = 200000;
  for (int i = 0; i < kSteps; ++i) {
    const double a = 0.6 * (i + 0.5) / kSteps;
    integral += spotFalloff(spot, std::cos(a)) * std::sin(a) * 0.6 / kSteps;
  }
  const glm::dvec3 power = lightPower(spot, Bounds3{});
  EXPECT_NEAR(power.x, 2.0 * std::numbers::pi * 80.0 * integral, 1e-6 * power.x);
}

TEST(ProgressiveLights, LuminaireFollowsItsPhotometricFile) {
  // A manufacturer's downlight (EULUMDAT, 24 C planes x 91 gamma angles) 2.8 m over the floor,
  // turned 30 degrees: every element's irradiance is I(C, gamma) cos(theta) / d^2 with I read
  // from the file (Photometry::intensity, independent of the LDT) and Wallner eq. 12's 683 lm/W.
  // It lights only downwards, so every probe ray finds the floor: the shot is closed.
  const std::string file = test::dataPath("photometry/ledvance_biolux_dn150.ldt");
  Expected<Photometry> photometry = readPhotometry(file);
  ASSERT_TRUE(photometry.ok()) << photometry.error().describe();
  Expected<std::shared_ptr<const LuminaireDistribution>> ldt = loadLuminaireDistribution(file);
  ASSERT_TRUE(ldt.ok()) << ldt.error().describe();
  LuminaireLight l;
  l.position = glm::vec3(0.4f, 2.8f, -0.3f);
  l.nadir = glm::vec3(0.0f, -1.0f, 0.0f);
  const double turn = glm::radians(30.0);
  l.c0 = glm::vec3(float(std::cos(turn)), 0.0f, float(std::sin(turn)));
  l.distribution = *ldt;
  l.scale = glm::vec3(float((*ldt)->max_candela / kLumensPerWatt));
  const Scene scene = floorScene(l);
  const glm::dvec3 c0(l.c0), c90(l.c90()), nadir(l.nadir), pos(l.position);
  size_t count = 0;
  const double peak = photometry->intensity(0.0, 0.0) / kLumensPerWatt / (2.8 * 2.8);
  const double worst = worstIrradianceError(
      scene,
      [&](const glm::dvec3& p) {
        const glm::dvec3 d = p - pos;
        const double r = glm::length(d);
        // The direction in the file's photometric frame (nadir -z, C0 +x, C90 +y).
        const glm::dvec3 local(glm::dot(d, c0), glm::dot(d, c90), -glm::dot(d, nadir));
        return photometry->intensity(local) / kLumensPerWatt * 2.8 / (r * r * r);
      },
      0.02 * peak, &count, /*closed=*/true, /*density=*/6.0);
  EXPECT_GT(count, 300u);
  EXPECT_LT(worst, 0.01) << "over " << count << " elements";
  // The light's power is the file's flux over 683 lm/W.
  EXPECT_NEAR(lightPower(Light(l), Bounds3{}).x * kLumensPerWatt / photometry->integratedFlux(),
              1.0, 2e-3);
}

TEST(ProgressiveLights, DirectionalLightGivesEcos) {
  const glm::vec3 dir = glm::normalize(glm::vec3(0.3f, -1.0f, 0.2f));
  const Scene scene = floorScene(DirectionalLight{dir, glm::vec3(3.0f)});
  size_t count = 0;
  const double expect = 3.0 * double(-dir.y);
  const double worst = worstIrradianceError(
      scene, [&](const glm::dvec3&) { return expect; }, 0.0, &count);
  EXPECT_GT(count, 1000u);
  EXPECT_LE(worst, 1e-6);
}

// A closed 4 x 3 x 5 m room lit by a ceiling panel, one wall wound facing out of the room.
Scene roomWithAWallWoundOutwards(bool two_sided) {
  Scene s;
  s.source = "test:room";
  s.materials = {{"paint", glm::vec3(0.7f, 0.6f, 0.5f), glm::vec3(0.0f)},
                 {"panel", glm::vec3(0.8f), glm::vec3(5.0f)}};
  for (Material& m : s.materials) m.two_sided = two_sided;
  Mesh m;
  m.name = "room";
  const float x = 4.0f, y = 3.0f, z = 5.0f;
  addQuad(m, {0, 0, 0}, {0, 0, z}, {x, 0, 0}, 0);  // floor, facing up
  addQuad(m, {0, y, 0}, {x, 0, 0}, {0, 0, z}, 0);  // ceiling, facing down
  addQuad(m, {0, 0, 0}, {x, 0, 0}, {0, y, 0}, 0);  // z = 0, facing +z
  addQuad(m, {0, 0, z}, {0, y, 0}, {x, 0, 0}, 0);  // z = 5, facing -z
  addQuad(m, {0, 0, 0}, {0, y, 0}, {0, 0, z}, 0);  // x = 0, facing +x
  addQuad(m, {x, 0, 0}, {0, y, 0}, {0, 0, z}, 0);  // x = 4: wound facing OUT (+x)
  // The panel, 1 cm below the ceiling, facing down.
  addQuad(m, {1.5f, y - 0.01f, 2.0f}, {1.0f, 0, 0}, {0, 0, 1.0f}, 1);
  s.meshes.push_back(m);
  return s;
}

TEST(ProgressiveLights, ClosedRoomLosesNothingWhateverTheWinding) {
  Scene scene = roomWithAWallWoundOutwards(true);
  ASSERT_TRUE(validateScene(scene).ok());
  ProgressiveOptions o;
  o.atlas.texel_density = 6.0;
  o.convergence = 1e-3;
  Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(scene, o);
  ASSERT_TRUE(pr.ok()) << pr.error().describe();
  const ProgressiveStats st = pr->solve();
  ASSERT_TRUE(st.converged);
  const EnergyBalance& b = pr->balance();
  // The wall wound outwards is lit from inside the room through its back face's elements.
  double back_wall = 0.0, back_area = 0.0;
  for (size_t e = 0; e < pr->elementCount(); ++e) {
    const SurfaceFace& f = pr->atlas().faces[pr->atlas().element_face[e]];
    if (f.triangle == 10 || f.triangle == 11) {
      if (f.back) {
        back_wall += pr->radiosity(e).x * pr->elementArea(e);
        back_area += pr->elementArea(e);
      } else {
        EXPECT_EQ(pr->radiosity(e), glm::dvec3(0.0));  // its front faces the outside
      }
    }
  }
  std::printf(
      "closed room, wall wound outwards: %d iterations; escaped %.2e of emitted; that wall's "
      "inside B %.3f W/m^2\n",
      st.iterations, b.escaped.x / b.emitted.x, back_wall / back_area);
  EXPECT_LE(std::abs(b.escaped.x) / b.emitted.x, 1e-6);
  EXPECT_LE(std::abs(b.escaped.y) / b.emitted.y, 1e-6);
  EXPECT_GT(back_wall / back_area, 0.1);
  // One-sided materials: the outward wall's inside is black, its light counts as escaped.
  Scene one = roomWithAWallWoundOutwards(false);
  ASSERT_TRUE(validateScene(one).ok());
  Expected<ProgressiveRadiosity> pr1 = ProgressiveRadiosity::build(one, o);
  ASSERT_TRUE(pr1.ok());
  pr1->solve();
  EXPECT_GT(pr1->balance().escaped.x / pr1->balance().emitted.x, 0.05);
}

}  // namespace
}  // namespace penumbra
