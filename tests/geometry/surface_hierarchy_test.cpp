// The multiresolution hierarchy: every level partitions the elements into contiguous clusters of
// one chart, clusters keep area, centroid and normal exactly, each chart ends in one root, and a
// cut gives the number of clusters asked for whatever the triangle count.
#include "penumbra/geometry/surface_hierarchy.h"
#include "penumbra/io/scene_io.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

namespace penumbra {
namespace {

struct Built {
  FlatTriangles flat;
  ChartAtlas atlas;
  SurfaceHierarchy hierarchy;
};

Built buildFor(const std::string& path, double density) {
  Built b;
  Expected<Scene> scene = loadScene(path);
  EXPECT_TRUE(scene.ok());
  b.flat = flattenScene(*scene);
  const std::vector<SurfaceFace> faces = surfaceFaces(*scene, b.flat);
  ChartAtlasOptions o;
  o.texel_density = density;
  Expected<ChartAtlas> a =
      buildChartAtlas(b.flat.positions, b.flat.triangles, b.flat.material_ids, faces, o);
  EXPECT_TRUE(a.ok()) << (a.ok() ? "" : a.error().message);
  b.atlas = std::move(*a);
  b.hierarchy = SurfaceHierarchy::build(b.atlas);
  return b;
}

TEST(SurfaceHierarchy, LevelsPartitionTheElementsByChart) {
  const Built b = buildFor("cornell", 40.0);
  const SurfaceHierarchy& h = b.hierarchy;
  const size_t n = b.atlas.elementCount();
  double total = 0.0;
  for (size_t e = 0; e < n; ++e) total += b.atlas.element_area[e];
  ASSERT_GE(h.levelCount(), 2u);
  for (size_t l = 0; l < h.levelCount(); ++l) {
    const ClusterLevel& lv = h.level(l);
    ASSERT_EQ(lv.first.front(), 0u);
    ASSERT_EQ(lv.first.back(), n);
    double area = 0.0;
    for (size_t k = 0; k < lv.size(); ++k) {
      ASSERT_LT(lv.first[k], lv.first[k + 1]);
      glm::dvec3 centroid(0.0), normal(0.0);
      double a = 0.0;
      for (uint32_t e = lv.first[k]; e < lv.first[k + 1]; ++e) {
        EXPECT_EQ(b.atlas.element_chart[e], lv.chart[k]);
        const glm::ivec2 t = b.atlas.texelOf(e);
        EXPECT_TRUE(t.x >= lv.lo[k].x && t.y >= lv.lo[k].y && t.x <= lv.hi[k].x &&
                    t.y <= lv.hi[k].y);
        // Within one 2^l block of the chart.
        const glm::ivec2 origin = b.atlas.placement[lv.chart[k]].origin;
        EXPECT_EQ((t - origin) >> int(l), (lv.lo[k] - origin) >> int(l));
        centroid += b.atlas.element_position[e] * b.atlas.element_area[e];
        normal += b.atlas.element_normal[e] * b.atlas.element_area[e];
        a += b.atlas.element_area[e];
      }
      EXPECT_NEAR(lv.area[k], a, 1e-12 * a);
      EXPECT_LT(glm::length(lv.position[k] - centroid / a), 1e-12);
      EXPECT_LT(glm::length(lv.normal[k] * lv.flatness[k] - normal / a), 1e-9);
      if (l > 0) {
        // Children: the level below's clusters whose elements these are.
        const ClusterLevel& below = h.level(l - 1);
        EXPECT_EQ(below.first[lv.child_first[k]], lv.first[k]);
        EXPECT_EQ(below.first[lv.child_first[k + 1]], lv.first[k + 1]);
        for (uint32_t c = lv.child_first[k]; c < lv.child_first[k + 1]; ++c) {
          EXPECT_EQ(below.parent[c], k);
        }
      }
      area += lv.area[k];
    }
    EXPECT_NEAR(area, total, 1e-9 * total);
  }
  // The Cornell box's faces are flat (its measured quads to within a fraction of a degree):
  // every cluster is flat.
  for (size_t l = 0; l < h.levelCount(); ++l) {
    for (double f : h.level(l).flatness) EXPECT_NEAR(f, 1.0, 1e-4);
  }
  // One root per chart, covering the chart's elements.
  for (uint32_t c = 0; c < h.chartCount(); ++c) {
    const ClusterRef r = h.root(c);
    EXPECT_EQ(h.elementBegin(r), b.atlas.placement[c].first_element);
    EXPECT_EQ(h.elementEnd(r) - h.elementBegin(r), b.atlas.placement[c].element_count);
  }
}

void expectCoverOnce(const Built& b, const std::vector<ClusterRef>& cut) {
  uint32_t next = 0;
  for (const ClusterRef& c : cut) {
    ASSERT_EQ(b.hierarchy.elementBegin(c), next);
    next = b.hierarchy.elementEnd(c);
  }
  EXPECT_EQ(next, b.atlas.elementCount());
}

TEST(SurfaceHierarchy, CutGivesTheClusterCountAskedForOnAScan) {
  // The bunny's 69,451 triangles at 1200 texels per metre: whatever the triangle count, a cut
  // gives n clusters (a refinement adds at most three), down to one per chart.
  const Built b = buildFor(test::dataPath("bunny.ply"), 1200.0);
  const size_t charts = b.atlas.chartCount();
  ASSERT_LT(charts, 3000u);
  for (size_t n : {size_t(3000), size_t(5000), size_t(20000)}) {
    const std::vector<ClusterRef> cut = b.hierarchy.cut(n);
    EXPECT_GE(cut.size(), n);
    EXPECT_LE(cut.size(), n + 3);
    expectCoverOnce(b, cut);
  }
  const std::vector<ClusterRef> roots = b.hierarchy.cut(1);
  EXPECT_EQ(roots.size(), charts);
  expectCoverOnce(b, roots);
  // Asking for more than the elements gives the elements.
  const std::vector<ClusterRef> all = b.hierarchy.cut(b.atlas.elementCount() * 2);
  EXPECT_EQ(all.size(), b.atlas.elementCount());
}

TEST(SurfaceHierarchy, InterpolationIsContinuousAndReproducesALinearField) {
  // A 5 x 3 m wall of two triangles at 20 texels per metre, cut into about 60 clusters (blocks
  // up to 16 x 16 texels, some cut short by the chart's edge). Cluster values of a linear field
  // f(p) = 2 x + y, taken at the clusters' centroids, interpolated to the elements: the result
  // follows f, and neighbouring texels differ by about one texel's step of f, not by a
  // cluster's (bands along the wall where blocks meet).
  const std::vector<glm::vec3> positions = {{0, 0, 0}, {5, 0, 0}, {5, 3, 0}, {0, 3, 0}};
  const std::vector<glm::uvec3> triangles = {{0, 1, 2}, {0, 2, 3}};
  const std::vector<uint32_t> materials = {0, 0};
  const std::vector<SurfaceFace> faces = {{0, false}, {1, false}};
  ChartAtlasOptions o;
  o.texel_density = 20.0;
  Expected<ChartAtlas> a = buildChartAtlas(positions, triangles, materials, faces, o);
  ASSERT_TRUE(a.ok()) << a.error().message;
  ASSERT_EQ(a->chartCount(), 1u);
  const SurfaceHierarchy h = SurfaceHierarchy::build(*a);
  const std::vector<ClusterRef> cut = h.cut(60);
  auto f = [](const glm::dvec3& p) { return 2.0 * p.x + p.y; };
  std::vector<glm::dvec3> values;
  uint32_t largest = 0;
  for (const ClusterRef& c : cut) {
    values.emplace_back(f(h.level(c.level).position[c.index]));
    largest = std::max(largest, h.elementEnd(c) - h.elementBegin(c));
  }
  ASSERT_GE(largest, 64u);  // blocks of at least 8 x 8 texels
  const std::vector<glm::dvec3> out = h.interpolate(*a, cut, values);
  ASSERT_EQ(out.size(), a->elementCount());
  const double texel = 1.0 / a->texel_density;
  const double step = 2.0 * texel;  // f's largest change from one texel to the next
  double worst_step = 0.0, worst_error = 0.0;
  for (uint32_t e = 0; e < a->elementCount(); ++e) {
    EXPECT_EQ(out[e].x, out[e].y);
    worst_error = std::max(worst_error, std::fabs(out[e].x - f(a->element_position[e])));
    const uint32_t t = a->element_texel[e];
    const int x = int(t % uint32_t(a->width)), y = int(t / uint32_t(a->width));
    for (const glm::ivec2 d : {glm::ivec2(1, 0), glm::ivec2(0, 1)}) {
      const int nx = x + d.x, ny = y + d.y;
      if (nx >= a->width || ny >= a->height) continue;
      const int32_t n = a->texel_element[size_t(ny) * size_t(a->width) + size_t(nx)];
      if (n < 0) continue;
      worst_step = std::max(worst_step, std::fabs(out[size_t(n)].x - out[e].x));
    }
  }
  std::printf(
      "interpolation on a wall: largest step %.3f (one texel of f: %.3f), largest error "
      "%.3f\n",
      worst_step, step, worst_error);
  // Bands would step by a block's width of f (8 texels and more); a box filter's slope is f's,
  // steeper by up to half where the window is clipped at the chart's edge.
  EXPECT_LE(worst_step, 3.0 * step);
  // Off f by at most half the largest block's width along both axes (flat at the edges):
  // (2 + 1) per metre times half a block.
  EXPECT_LE(worst_error, 3.0 * 0.5 * std::sqrt(double(largest)) * texel * 1.01);
}

}  // namespace
}  // namespace penumbra
