// Matrix radiosity with point lights: the direct term B = E + rho * direct + rho F B, the
// irradiance taken at every lightmap element's point with a Ray Engine shadow ray (so shadows are
// as sharp as the lightmap, whatever the number of clusters).
#include "penumbra/radiosity/matrix_radiosity.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <cmath>

namespace penumbra {
namespace {
using test::addQuad;

TEST(MatrixRadiosity, PointLightGivesTheInverseSquareDirectTermAndShadows) {
  // A 10 m floor (facing up) under a point light 2 m above it, and a 1 m blocker (facing up,
  // 1 m above the floor) that shadows part of it.
  Scene s;
  s.source = "test:floor";
  s.materials = {{"floor", glm::vec3(0.5f), glm::vec3(0.0f)},
                 {"blocker", glm::vec3(0.0f), glm::vec3(0.0f)}};
  Mesh m;
  m.name = "floor";
  addQuad(m, {-5, 0, -5}, {0, 0, 10}, {10, 0, 0}, 0);
  addQuad(m, {2.0f, 1.0f, -0.5f}, {0, 0, 1}, {1, 0, 0}, 1);  // x in [2, 3]
  s.meshes.push_back(m);
  const glm::dvec3 light(0.0, 2.0, 0.0);
  const double intensity = 20.0;
  s.lights.push_back(PointLight{glm::vec3(light), glm::vec3(float(intensity))});
  ASSERT_TRUE(validateScene(s).ok());

  MatrixRadiosityOptions o;
  o.elements = 1200;
  Expected<MatrixRadiosity> mr = buildMatrixRadiosity(s, o);
  ASSERT_TRUE(mr.ok()) << mr.error().describe();
  SolveOptions so;
  so.tolerance = 1e-12;
  ASSERT_TRUE(mr->solve(so).converged);
  double worst = 0.0;
  size_t lit = 0, shadowed = 0;
  const std::vector<glm::dvec3> radiosity = mr->elementRadiosity();
  const ChartAtlas& atlas = mr->surface.atlas;
  for (size_t e = 0; e < radiosity.size(); ++e) {
    if (mr->surface.material[e] != 0 || atlas.element_normal[e].y < 0.5) continue;
    const glm::dvec3 p(atlas.element_position[e]);
    // Behind the blocker as seen from the light: the segment to the light crosses y = 1 inside
    // the blocker's square (x in [2, 3], z in [-0.5, 0.5]), with a margin for the element size.
    const double t = (1.0 - p.y) / (light.y - p.y);
    const glm::dvec3 q = p + t * (light - p);
    const bool inside = q.x > 2.1 && q.x < 2.9 && std::abs(q.z) < 0.4;
    const bool outside = q.x < 1.9 || q.x > 3.1 || std::abs(q.z) > 0.6;
    const double b = radiosity[e].x;
    if (inside) {
      EXPECT_EQ(b, 0.0);
      ++shadowed;
      continue;
    }
    if (!outside) continue;
    const double r = glm::length(light - p);
    const double expect = 0.5 * intensity * (light.y - p.y) / (r * r * r);  // rho I cos / r^2
    worst = std::max(worst, std::abs(b / expect - 1.0));
    ++lit;
  }
  std::printf("matrix, point light: %zu lit elements worst %.2e, %zu shadowed\n", lit, worst,
              shadowed);
  EXPECT_GT(lit, 500u);
  EXPECT_GT(shadowed, 100u);
  EXPECT_LE(worst, 1e-5);  // a flat floor sees nothing of itself: B is the direct term alone
}

}  // namespace
}  // namespace penumbra
