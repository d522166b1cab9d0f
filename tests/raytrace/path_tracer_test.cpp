// The reference path tracer against closed forms.
#include "penumbra/raytrace/path_tracer.h"

#include "penumbra/core/parallel.h"
#include "penumbra/kernels/sampling.h"
#include "penumbra/scene/builtin.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>

#include <cmath>

namespace penumbra {
namespace {

// A scene with a large horizontal floor (y = 0) of reflectance rho.
Scene floorScene(float rho, float half_size = 1000.0f) {
  Scene s;
  s.source = "test:floor";
  s.materials.push_back({"floor", glm::vec3(rho), glm::vec3(0.0f)});
  Mesh m;
  m.name = "floor";
  const float h = half_size;
  m.positions = {{-h, 0, -h}, {-h, 0, h}, {h, 0, h}, {h, 0, -h}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  m.material_ids = {0, 0};
  s.meshes.push_back(m);
  return s;
}

// Mean radiance of `n` samples along the ray from `eye` to `target`.
glm::vec3 meanRadiance(const PathTracer& pt, glm::vec3 eye, glm::vec3 target, int n) {
  Rng rng(1, 2);
  PathTracerSettings settings;
  uint64_t rays = 0;
  glm::dvec3 sum(0.0);
  Ray ray;
  ray.origin = eye;
  ray.dir = glm::normalize(target - eye);
  for (int i = 0; i < n; ++i) sum += glm::dvec3(pt.radiance(ray, rng, settings, rays));
  return glm::vec3(sum / double(n));
}

TEST(PathTracer, PointLightFollowsTheInverseSquareCosineLaw) {
  Scene s = floorScene(0.5f);
  const glm::vec3 light_pos(0.0f, 2.0f, 0.0f);
  s.lights.push_back(PointLight{light_pos, glm::vec3(10.0f, 5.0f, 1.0f)});
  ASSERT_TRUE(validateScene(s).ok());
  const PathTracer pt(s);
  for (const glm::vec3 x :
       {glm::vec3(0, 0, 0), glm::vec3(1, 0, 0.5f), glm::vec3(3, 0, 0), glm::vec3(-6, 0, 2)}) {
    const glm::vec3 d = light_pos - x;
    const float r2 = glm::dot(d, d);
    const float cos_theta = d.y / std::sqrt(r2);
    const glm::vec3 expected = 0.5f * kInvPi * glm::vec3(10.0f, 5.0f, 1.0f) * cos_theta / r2;
    const glm::vec3 got = meanRadiance(pt, x + glm::vec3(0.3f, 1.0f, -0.2f), x, 16);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], expected[c], 1e-4f * expected[c]) << x.x;
  }
}

TEST(PathTracer, SpotLightFallsOffBetweenItsCones) {
  Scene s = floorScene(0.8f, 10.0f);  // small, so hit points carry little rounding error
  SpotLight spot;
  spot.position = glm::vec3(0.0f, 1.0f, 0.0f);
  spot.direction = glm::vec3(0.0f, -1.0f, 0.0f);
  spot.intensity = glm::vec3(4.0f);
  spot.inner_angle = glm::radians(20.0f);
  spot.outer_angle = glm::radians(40.0f);
  s.lights.push_back(spot);
  ASSERT_TRUE(validateScene(s).ok());
  const PathTracer pt(s);
  for (const float angle_deg : {0.0f, 10.0f, 30.0f, 35.0f, 45.0f}) {
    const float a = glm::radians(angle_deg);
    const glm::vec3 x(std::tan(a), 0.0f, 0.0f);
    float falloff = 1.0f;
    if (angle_deg > 20.0f) {
      const float f =
          std::clamp((std::cos(a) - std::cos(glm::radians(40.0f))) /
                         (std::cos(glm::radians(20.0f)) - std::cos(glm::radians(40.0f))),
                     0.0f, 1.0f);
      falloff = f * f;
    }
    const float r2 = 1.0f + x.x * x.x;
    const float expected = 0.8f * kInvPi * 4.0f * falloff * std::cos(a) / r2;
    const glm::vec3 got = meanRadiance(pt, x + glm::vec3(0.0f, 0.5f, 0.5f), x, 4);
    EXPECT_NEAR(got.x, expected, 1e-4f * std::max(expected, 1e-3f)) << angle_deg;
  }
}

TEST(PathTracer, DirectionalLightGivesRhoOverPiTimesIrradianceCosine) {
  Scene s = floorScene(0.6f);
  s.lights.push_back(
      DirectionalLight{glm::normalize(glm::vec3(1.0f, -1.0f, 0.0f)), glm::vec3(3.0f)});
  ASSERT_TRUE(validateScene(s).ok());
  const PathTracer pt(s);
  const glm::vec3 got = meanRadiance(pt, glm::vec3(0.0f, 1.0f, 1.0f), glm::vec3(0.0f), 4);
  EXPECT_NEAR(got.x, 0.6f * kInvPi * 3.0f * std::sqrt(0.5f), 1e-5f);
}

// Lambert's formula for the form factor from a differential area at x (normal n) to a polygon.
double pointToPolygonFormFactor(glm::dvec3 x, glm::dvec3 n, const std::vector<glm::dvec3>& poly) {
  double sum = 0.0;
  for (size_t i = 0; i < poly.size(); ++i) {
    const glm::dvec3 a = glm::normalize(poly[i] - x);
    const glm::dvec3 b = glm::normalize(poly[(i + 1) % poly.size()] - x);
    const double gamma = std::acos(std::clamp(glm::dot(a, b), -1.0, 1.0));
    sum += gamma * glm::dot(n, glm::normalize(glm::cross(a, b)));
  }
  return std::fabs(sum) / (2.0 * 3.14159265358979323846);
}

// An emissive square above the floor: radiance leaving the floor is rho * Le * F(x -> square),
// which exercises emitter sampling, BSDF sampling and their MIS weights together.
TEST(PathTracer, AreaLightMatchesThePointToPolygonFormFactor) {
  Scene s = floorScene(0.5f);
  s.materials.push_back({"emitter", glm::vec3(0.0f), glm::vec3(2.0f)});
  Mesh e;
  e.name = "emitter";
  const std::vector<glm::dvec3> quad = {
      {-0.5, 1, -0.5}, {0.5, 1, -0.5}, {0.5, 1, 0.5}, {-0.5, 1, 0.5}};
  for (const auto& q : quad) e.positions.emplace_back(q);
  e.triangles = {{0, 1, 2}, {0, 2, 3}};  // counter-clockwise from below: faces down
  e.material_ids = {1, 1};
  s.meshes.push_back(e);
  ASSERT_TRUE(validateScene(s).ok());
  const PathTracer pt(s);
  for (const glm::vec3 x : {glm::vec3(0, 0, 0), glm::vec3(0.8f, 0, 0.3f), glm::vec3(2.0f, 0, 0)}) {
    const double f = pointToPolygonFormFactor(glm::dvec3(x), glm::dvec3(0, 1, 0), quad);
    const double expected = 0.5 * 2.0 * f;
    const glm::vec3 got = meanRadiance(pt, x + glm::vec3(1.5f, 0.4f, 0.0f), x, 40000);
    EXPECT_NEAR(got.x, expected, 0.01 * expected) << "at x = " << x.x << ", F = " << f;
  }
}

TEST(PathTracer, FurnaceGivesRadianceTwo) {
  Expected<Scene> s = builtinScene("furnace");
  ASSERT_TRUE(s.ok());
  const PathTracer pt(*s);
  PathTracerSettings settings;
  settings.width = settings.height = 24;
  settings.spp = 256;
  const Image img = pt.render(*s->camera, settings);
  double sum = 0.0;
  float worst = 0.0f;
  for (const glm::vec3& p : img.pixels) {
    sum += double(p.x + p.y + p.z) / 3.0;
    worst = std::max(worst, std::fabs(p.x - 2.0f));
  }
  const double mean = sum / double(img.pixels.size());
  EXPECT_NEAR(mean, 2.0, 0.02);  // 1% over the image
  EXPECT_LT(worst, 0.2f);        // and no pixel far off
}

TEST(PathTracer, ImageDoesNotDependOnTheThreadCount) {
  Expected<Scene> s = builtinScene("cornell");
  ASSERT_TRUE(s.ok());
  const PathTracer pt(*s);
  PathTracerSettings settings;
  settings.width = settings.height = 24;
  settings.spp = 8;
  settings.seed = 42;
  Image one, two;
  {
    auto limit = limitThreads(1);
    one = pt.render(*s->camera, settings);
  }
  {
    auto limit = limitThreads(2);
    two = pt.render(*s->camera, settings);
  }
  for (size_t i = 0; i < one.pixels.size(); ++i) ASSERT_EQ(one.pixels[i], two.pixels[i]) << i;
  settings.seed = 43;
  const Image other = pt.render(*s->camera, settings);
  EXPECT_NE(other.pixels, one.pixels);  // the seed matters
}

}  // namespace
}  // namespace penumbra
