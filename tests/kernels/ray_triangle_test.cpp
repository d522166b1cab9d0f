// The watertight ray-triangle test (Woop et al. 2013) on its edge cases.
#include "penumbra/kernels/ray_triangle.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <cmath>
#include <limits>

namespace penumbra {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

struct Result {
  bool hit;
  float t, u, v;
};

Result hitTriangle(glm::vec3 o, glm::vec3 d, glm::vec3 p0, glm::vec3 p1, glm::vec3 p2,
                   float tmin = 0.0f, float tmax = kInf) {
  Result r{};
  r.hit = intersectTriangle(makeWatertightRay(o, d), p0, p1, p2, tmin, tmax, r.t, r.u, r.v);
  return r;
}

const glm::vec3 kP0(0, 0, 0), kP1(1, 0, 0), kP2(0, 1, 0);  // in the z = 0 plane

TEST(RayTriangle, InteriorHitGivesDistanceAndBarycentrics) {
  const Result r = hitTriangle({0.25f, 0.5f, 2.0f}, {0, 0, -1}, kP0, kP1, kP2);
  ASSERT_TRUE(r.hit);
  EXPECT_FLOAT_EQ(r.t, 2.0f);
  EXPECT_FLOAT_EQ(r.u, 0.25f);  // weight of p1 = x
  EXPECT_FLOAT_EQ(r.v, 0.5f);   // weight of p2 = y
}

TEST(RayTriangle, BothFacesAreHit) {
  EXPECT_TRUE(hitTriangle({0.2f, 0.2f, 1.0f}, {0, 0, -1}, kP0, kP1, kP2).hit);
  EXPECT_TRUE(hitTriangle({0.2f, 0.2f, -1.0f}, {0, 0, 1}, kP0, kP1, kP2).hit);
}

TEST(RayTriangle, DistanceScalesWithDirectionLength) {
  const Result r = hitTriangle({0.2f, 0.2f, 4.0f}, {0, 0, -2}, kP0, kP1, kP2);
  ASSERT_TRUE(r.hit);
  EXPECT_FLOAT_EQ(r.t, 2.0f);
}

TEST(RayTriangle, EdgesAndVerticesAreHit) {
  // Exactly through the middle of each edge and through each vertex.
  const glm::vec3 d(0.0f, 0.0f, -1.0f);
  for (const glm::vec3 target :
       {glm::vec3(0.5f, 0, 0), glm::vec3(0, 0.5f, 0), glm::vec3(0.5f, 0.5f, 0), kP0, kP1, kP2}) {
    const glm::vec3 o = target - 3.0f * d;
    const Result r = hitTriangle(o, d, kP0, kP1, kP2);
    EXPECT_TRUE(r.hit) << "target " << target.x << " " << target.y;
  }
}

TEST(RayTriangle, SharedEdgeIsNeverMissedByBothTriangles) {
  // A quad split along its diagonal; rays aimed at points on the diagonal (where float
  // rounding makes a naive test miss both halves) must hit at least one.
  const glm::vec3 a(0, 0, 0), b(1, 0, 0), c(1, 1, 0), d(0, 1, 0);
  int missed = 0;
  for (int i = 0; i <= 1000; ++i) {
    const float s = float(i) / 1000.0f;
    const glm::vec3 target(s, s, 0.0f);
    const glm::vec3 dir = glm::normalize(glm::vec3(0.37f, -0.11f, -1.0f));
    const glm::vec3 o = target - 1.7f * dir;
    const bool h1 = hitTriangle(o, dir, a, b, c).hit;
    const bool h2 = hitTriangle(o, dir, a, c, d).hit;
    missed += !(h1 || h2);
  }
  EXPECT_EQ(missed, 0);
}

TEST(RayTriangle, ParallelRaysMiss) {
  // In the triangle's plane and parallel above it.
  EXPECT_FALSE(hitTriangle({-1, 0.2f, 0}, {1, 0, 0}, kP0, kP1, kP2).hit);
  EXPECT_FALSE(hitTriangle({-1, 0.2f, 0.5f}, {1, 0, 0}, kP0, kP1, kP2).hit);
}

TEST(RayTriangle, HitsBehindTheOriginAreIgnored) {
  EXPECT_FALSE(hitTriangle({0.2f, 0.2f, -1.0f}, {0, 0, -1}, kP0, kP1, kP2).hit);
}

TEST(RayTriangle, TminAndTmaxAreHonoured) {
  const glm::vec3 o(0.2f, 0.2f, 5.0f), d(0, 0, -1);
  EXPECT_FALSE(hitTriangle(o, d, kP0, kP1, kP2, 0.0f, 4.999f).hit);
  EXPECT_FALSE(hitTriangle(o, d, kP0, kP1, kP2, 5.001f, kInf).hit);
  EXPECT_TRUE(hitTriangle(o, d, kP0, kP1, kP2, 0.0f, 5.001f).hit);
  EXPECT_TRUE(hitTriangle(o, d, kP0, kP1, kP2, 4.999f, kInf).hit);
  // The interval is closed: the exact distance is inside it.
  EXPECT_TRUE(hitTriangle(o, d, kP0, kP1, kP2, 0.0f, 5.0f).hit);
}

TEST(RayTriangle, DegenerateTrianglesAreNeverHit) {
  EXPECT_FALSE(hitTriangle({0.5f, 0, 1}, {0, 0, -1}, kP0, kP1, glm::vec3(2, 0, 0)).hit);
  EXPECT_FALSE(hitTriangle({0, 0, 1}, {0, 0, -1}, kP0, kP0, kP0).hit);
}

TEST(RayTriangle, MissesOutside) {
  EXPECT_FALSE(hitTriangle({0.6f, 0.6f, 1}, {0, 0, -1}, kP0, kP1, kP2).hit);
  EXPECT_FALSE(hitTriangle({-0.01f, 0.5f, 1}, {0, 0, -1}, kP0, kP1, kP2).hit);
}

}  // namespace
}  // namespace penumbra
