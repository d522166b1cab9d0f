// The multiresolution hierarchy: every level partitions the elements into contiguous clusters of
// one chart, clusters keep area, centroid and normal exactly, each chart ends in one root, and a
// cut gives the number of clusters asked for whatever the triangle count.
#include "penumbra/geometry/surface_hierarchy.h"
#include "penumbra/io/scene_io.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

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

}  // namespace
}  // namespace penumbra
