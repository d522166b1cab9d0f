// Marching tetrahedra (geometry/isosurface.h): a sphere's level set is a closed, outward-wound
// mesh with the sphere's area and volume, and the built-in `blobs` animation changes topology:
// two spheres (Euler characteristic 4) that merge into one surface (2).
#include "penumbra/geometry/isosurface.h"
#include "penumbra/scene/animation.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <numeric>
#include <utility>
#include <vector>

namespace penumbra {
namespace {

struct Topology {
  size_t open_edges = 0;  // edges not shared by exactly two triangles
  int euler = 0;          // V - E + F
  size_t components = 0;
  double area = 0.0, volume = 0.0;
};

Topology topology(const Mesh& m) {
  Topology t;
  std::map<std::pair<uint32_t, uint32_t>, int> edges;
  std::vector<uint32_t> parent(m.positions.size());
  std::iota(parent.begin(), parent.end(), 0u);
  auto find = [&](uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  std::vector<uint8_t> used(m.positions.size(), 0);
  for (const glm::uvec3& tri : m.triangles) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = tri[k], b = tri[(k + 1) % 3];
      ++edges[{std::min(a, b), std::max(a, b)}];
      parent[find(a)] = find(b);
      used[a] = 1;
    }
    const glm::dvec3 p0(m.positions[tri.x]), p1(m.positions[tri.y]), p2(m.positions[tri.z]);
    t.area += 0.5 * glm::length(glm::cross(p1 - p0, p2 - p0));
    t.volume += glm::dot(p0, glm::cross(p1, p2)) / 6.0;
  }
  for (const auto& [e, n] : edges) t.open_edges += n != 2;
  size_t vertices = 0;
  for (uint32_t v = 0; v < m.positions.size(); ++v) {
    if (!used[v]) continue;
    ++vertices;
    t.components += find(v) == v;
  }
  t.euler = int(vertices) - int(edges.size()) + int(m.triangles.size());
  return t;
}

TEST(Isosurface, SphereIsClosedOutwardAndMeasuresRight) {
  const double r = 0.03;
  const Mesh m = isosurfaceMesh([&](const glm::dvec3& p) { return r * r - glm::dot(p, p); },
                                glm::dvec3(-0.05), glm::dvec3(0.05), 40);
  const Topology t = topology(m);
  const double area = 4.0 * std::numbers::pi * r * r,
               volume = 4.0 / 3.0 * std::numbers::pi * r * r * r;
  std::printf("sphere: %zu triangles, area %.4f of 4 pi r^2, volume %.4f of 4/3 pi r^3, euler %d\n",
              m.triangles.size(), t.area / area, t.volume / volume, t.euler);
  EXPECT_EQ(t.open_edges, 0u);
  EXPECT_EQ(t.components, 1u);
  EXPECT_EQ(t.euler, 2);
  EXPECT_NEAR(t.volume / volume, 1.0, 0.01);  // positive: wound outwards
  EXPECT_NEAR(t.area / area, 1.0, 0.05);
}

TEST(Isosurface, BlobsMergeFromTwoSurfacesIntoOne) {
  const std::optional<SceneAnimation> blobs = builtinAnimation("blobs");
  ASSERT_TRUE(blobs.has_value());
  const std::pair<double, size_t> expected[] = {{0.0, 2}, {0.4, 2}, {0.8, 1}, {0.99, 1}};
  for (const auto& [time, components] : expected) {
    Expected<Scene> s = (*blobs)(time);
    ASSERT_TRUE(s.ok()) << s.error().describe();
    const Topology t = topology(s->meshes[0]);
    std::printf("blobs at t = %.2f: %zu triangles, %zu component(s), euler %d\n", time,
                s->meshes[0].triangles.size(), t.components, t.euler);
    EXPECT_EQ(t.open_edges, 0u) << time;
    EXPECT_EQ(t.components, components) << time;
    EXPECT_EQ(t.euler, int(2 * components)) << time;
    EXPECT_GT(t.volume, 0.0) << time;
  }
}

}  // namespace
}  // namespace penumbra
