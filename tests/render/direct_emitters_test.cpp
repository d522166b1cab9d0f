// Exact direct light from area emitters (render/direct_emitters.h) against closed forms: the
// form factor from a point to a parallel rectangle over one of its corners (Howell's catalogue
// B-3, independent of Lambert's polygon formula the code uses), the same with half the emitter
// hidden by an opaque edge, and the cylindrical illuminance of a small distant emitter.
#include "penumbra/render/direct_emitters.h"
#include "penumbra/render/illuminance.h"
#include "support/test_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace penumbra {
namespace {

using test::addQuad;

// The form factor from a differential area to a parallel a x b rectangle at distance h, the
// area's normal through one of the rectangle's corners (Howell, "A Catalog of Radiation Heat
// Transfer Configuration Factors", B-3).
double cornerFormFactor(double a, double b, double h) {
  const double x = a / h, y = b / h;
  const double sx = std::sqrt(1.0 + x * x), sy = std::sqrt(1.0 + y * y);
  return (x / sx * std::atan(y / sx) + y / sy * std::atan(x / sy)) / (2.0 * std::numbers::pi);
}

struct EmitterScene {
  Scene scene;
  FlatTriangles flat;
  RayEngine engine;
};

// A rectangular emitter of radiance 1 W m^-2 sr^-1 facing down, corners (0, h, 0) and (a, h, b).
EmitterScene emitterScene(double a, double b, double h) {
  EmitterScene s;
  s.scene.source = "test:emitter";
  s.scene.materials = {{"panel", glm::vec3(0.0f), glm::vec3(1.0f)}};
  Mesh m;
  addQuad(m, {0, float(h), 0}, {float(a), 0, 0}, {0, 0, float(b)}, 0);
  s.scene.meshes.push_back(m);
  s.flat = flattenScene(s.scene);
  s.engine = RayEngine::build(s.flat.positions, s.flat.triangles);
  return s;
}

TEST(AreaEmitters, UnoccludedIrradianceIsTheClosedForm) {
  for (const double h : {0.2, 1.0, 3.0}) {
    const EmitterScene s = emitterScene(1.0, 2.0, h);
    const AreaEmitters emitters(s.scene, s.flat);
    ASSERT_EQ(emitters.size(), 2u);
    EXPECT_TRUE(emitters.handles(0) && emitters.handles(1));
    Rng rng(1, 2);
    uint64_t rays = 0;
    const glm::dvec3 e =
        emitters.irradiance(s.engine, glm::dvec3(0.0), glm::dvec3(0, 1, 0), 1e-6, rng, rays);
    const double expected = std::numbers::pi * cornerFormFactor(1.0, 2.0, h);
    EXPECT_NEAR(e.x, expected, 1e-9 * expected) << h;
    EXPECT_LT(rays, uint64_t(AreaEmitters::kFirstRays + 32)) << "no penumbra, no refinement";
    // Behind the emitting face: nothing.
    const glm::dvec3 back = emitters.irradiance(s.engine, glm::dvec3(0.5, h + 1.0, 0.5),
                                                glm::dvec3(0, -1, 0), 1e-6, rng, rays);
    EXPECT_EQ(back.x, 0.0);
  }
}

TEST(AreaEmitters, HalfHiddenEmitterGivesTheVisibleHalfsFormFactor) {
  // The emitter spans x in [-1, 1] over the point; the blocker hides x < 0 of it.
  EmitterScene s;
  s.scene.source = "test:half";
  s.scene.materials = {{"panel", glm::vec3(0.0f), glm::vec3(1.0f)},
                       {"black", glm::vec3(0.0f), glm::vec3(0.0f)}};
  Mesh m;
  addQuad(m, {-1, 2, -0.5f}, {2, 0, 0}, {0, 0, 1}, 0);
  addQuad(m, {-20, 1, -20}, {20, 0, 0}, {0, 0, 40}, 1);  // x < 0 at height 1, facing down
  s.scene.meshes.push_back(m);
  s.flat = flattenScene(s.scene);
  s.engine = RayEngine::build(s.flat.positions, s.flat.triangles);
  const AreaEmitters emitters(s.scene, s.flat);
  // The visible part, x in [0, 1], z in [-0.5, 0.5]: two corner rectangles of 1 x 0.5.
  const double expected = std::numbers::pi * 2.0 * cornerFormFactor(1.0, 0.5, 2.0);
  double lo = 1e30, hi = 0.0;
  for (uint64_t seed = 0; seed < 8; ++seed) {
    Rng rng(seed, 7);
    uint64_t rays = 0;
    const double e =
        emitters.irradiance(s.engine, glm::dvec3(0.0), glm::dvec3(0, 1, 0), 1e-6, rng, rays).x;
    EXPECT_NEAR(e / expected, 1.0, 0.01) << seed;
    EXPECT_GT(rays, uint64_t(AreaEmitters::kPenumbraRays)) << "a penumbra is refined";
    lo = std::min(lo, e);
    hi = std::max(hi, e);
  }
  std::printf("half-hidden emitter: %.5f to %.5f over 8 seeds, exact %.5f\n", lo, hi, expected);
  EXPECT_LT((hi - lo) / expected, 0.01);  // 8 seeds: about 4 standard deviations
}

TEST(AreaEmitters, CylindricalIlluminanceOfASmallEmitterIsItsIntensityOverPiD2) {
  // A 2 cm square emitter 3 m away at the height of the point, facing it: its intensity is
  // L A, seen square to the axis, so E_z = L A / (pi d^2).
  EmitterScene s;
  s.scene.source = "test:cyl";
  s.scene.materials = {{"panel", glm::vec3(0.0f), glm::vec3(1.0f)}};
  Mesh m;
  addQuad(m, {3, -0.01f, -0.01f}, {0, 0, 0.02f}, {0, 0.02f, 0}, 0);  // facing -x
  s.scene.meshes.push_back(m);
  s.flat = flattenScene(s.scene);
  s.engine = RayEngine::build(s.flat.positions, s.flat.triangles);
  const AreaEmitters emitters(s.scene, s.flat);
  Rng rng(3, 4);
  uint64_t rays = 0;
  const double e =
      emitters
          .cylindricalIrradiance(s.engine, glm::dvec3(0.0), glm::dvec3(0, 1, 0), 1e-6, rng, rays)
          .x;
  const double expected = 0.02 * 0.02 / (std::numbers::pi * 9.0);
  EXPECT_NEAR(e / expected, 1.0, 1e-3);
  // About the axis pointing at it, the emitter lies on the axis: no cylindrical illuminance.
  const double along =
      emitters
          .cylindricalIrradiance(s.engine, glm::dvec3(0.0), glm::dvec3(1, 0, 0), 1e-6, rng, rays)
          .x;
  EXPECT_LT(along, 0.01 * expected);  // only the emitter's 1 cm half-width off the axis
}

TEST(AreaEmitters, CylindricalGridOfAPointLight) {
  // gatherIlluminance with Measure::kCylindrical: an isotropic point light of intensity I at
  // horizontal distance d and height difference z gives E_z = I sin(alpha) / (pi r^2),
  // alpha the angle from the vertical axis, r^2 = d^2 + z^2.
  Scene scene;
  scene.source = "test:cylpoint";
  scene.materials = {{"black", glm::vec3(0.0f), glm::vec3(0.0f)}};
  Mesh m;
  addQuad(m, {-50, -10, -50}, {0, 0, 100}, {100, 0, 0}, 0);  // a floor far below, facing up
  scene.meshes.push_back(m);
  PointLight light;
  light.position = glm::vec3(2.0f, 1.5f, 0.0f);
  light.intensity = glm::vec3(1.0f);
  scene.lights.push_back(light);
  const FlatTriangles flat = flattenScene(scene);
  const RayEngine engine = RayEngine::build(flat.positions, flat.triangles);
  CalculationGrid grid;
  grid.measure = Measure::kCylindrical;
  grid.points = {glm::dvec3(0.0)};
  grid.normals = {glm::dvec3(0, 1, 0)};
  const IlluminanceResult r = gatherIlluminance(
      scene, engine, flat, grid, [](const Ray&, const Hit&, Rng&) { return glm::vec3(0.0f); }, 64,
      1);
  const double r2 = 4.0 + 2.25, sin_a = 2.0 / std::sqrt(r2);
  const double expected = luxOf(glm::dvec3(1.0)) * sin_a / (std::numbers::pi * r2);
  EXPECT_NEAR(r.total[0] / expected, 1.0, 1e-6);
}

}  // namespace
}  // namespace penumbra
