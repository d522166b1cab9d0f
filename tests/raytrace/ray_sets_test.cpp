// The ray sets of `penumbra rays`: camera rays through pixel centres, and diffuse rays whose
// origins are uniform over the surface (by area), whose side is either with probability 1/2 and
// whose directions are cosine-distributed (E[cos] = 2/3, E[cos^2] = 1/2).
#include "penumbra/raytrace/ray_sets.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <cmath>

namespace penumbra {
namespace {

TEST(RaySets, CameraRaysGoThroughPixelCentresRowByRowFromTheTop) {
  Camera cam;
  cam.position = glm::vec3(0, 0, 5);
  cam.look_at = glm::vec3(0);
  const RayBatch b = cameraRaySet(cam, 3, 2);
  ASSERT_EQ(b.size(), 6u);
  for (size_t i = 0; i < b.size(); ++i) {
    const Ray r = b.get(i);
    EXPECT_EQ(r.origin, cam.position);
    EXPECT_NEAR(glm::length(r.dir), 1.0f, 1e-6f);
    EXPECT_EQ(r.tmin, 0.0f);
    EXPECT_TRUE(std::isinf(r.tmax));
  }
  // Pixel (1, y) is the middle column: no sideways component; the top row looks up.
  EXPECT_NEAR(b.get(1).dir.x, 0.0f, 1e-6f);
  EXPECT_GT(b.get(1).dir.y, 0.0f);
  EXPECT_LT(b.get(4).dir.y, 0.0f);
  EXPECT_NEAR(b.get(1).dir.y, -b.get(4).dir.y, 1e-6f);
  EXPECT_LT(b.get(0).dir.x, 0.0f);
  EXPECT_GT(b.get(2).dir.x, 0.0f);
}

TEST(RaySets, DiffuseRaysAreUniformByAreaCosineDistributedAndLeaveBothSides) {
  // Two triangles in the plane z = 0: areas 2 and 0.5 (a fifth of the rays on the small one),
  // and a degenerate one that must never be chosen.
  const std::vector<glm::vec3> p = {{0, 0, 0},  {2, 0, 0},  {0, 2, 0}, {10, 0, 0},
                                    {11, 0, 0}, {10, 1, 0}, {5, 5, 0}, {6, 6, 0}};
  const std::vector<glm::uvec3> t = {{0, 1, 2}, {3, 4, 5}, {6, 7, 6}};
  const size_t n = 200000;
  const RayBatch b = diffuseRaySet(p, t, n, 3, 1e-3f);
  ASSERT_EQ(b.size(), n);
  size_t small = 0, up = 0;
  double mean_cos = 0.0, mean_cos2 = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const Ray r = b.get(i);
    ASSERT_EQ(r.origin.z, 0.0f);
    ASSERT_NEAR(glm::length(r.dir), 1.0f, 1e-5f);
    ASSERT_EQ(r.tmin, 1e-3f);
    const bool on_small = r.origin.x >= 10.0f;
    if (on_small) {
      ++small;
      ASSERT_LE(r.origin.x - 10.0f + r.origin.y, 1.0f + 1e-5f);
    } else {
      ASSERT_LE(r.origin.x + r.origin.y, 2.0f + 1e-5f);
    }
    up += r.dir.z > 0.0f;
    const double c = std::abs(double(r.dir.z));
    mean_cos += c / double(n);
    mean_cos2 += c * c / double(n);
  }
  // Binomial standard deviations: sqrt(0.2 * 0.8 / n) = 0.0009, sqrt(0.25 / n) = 0.0011.
  EXPECT_NEAR(double(small) / double(n), 0.2, 0.005);
  EXPECT_NEAR(double(up) / double(n), 0.5, 0.006);
  EXPECT_NEAR(mean_cos, 2.0 / 3.0, 0.003);
  EXPECT_NEAR(mean_cos2, 0.5, 0.003);
  // Deterministic for a seed, different for another.
  const RayBatch again = diffuseRaySet(p, t, 1000, 3, 1e-3f);
  const RayBatch other = diffuseRaySet(p, t, 1000, 4, 1e-3f);
  EXPECT_EQ(std::vector<float>(again.dx.begin(), again.dx.end()),
            std::vector<float>(b.dx.begin(), b.dx.begin() + 1000));
  EXPECT_NE(other.dx, again.dx);
  // No area, no rays.
  EXPECT_EQ(diffuseRaySet(p, {{6, 7, 6}}, 10, 0, 0.0f).size(), 0u);
}

}  // namespace
}  // namespace penumbra
