// The chart atlas: charts group faces by area rather than count (a wall gets the texels its area
// deserves), footprints of different charts never share a texel, every face is covered exactly
// once by its chart's elements, a bilinear lookup anywhere on a face reads only its own chart's
// texels, stretch stays bounded, and real meshes pack with >= 60% utilisation.
#include "penumbra/geometry/chart_atlas.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/scene/scene.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <cmath>
#include <vector>

namespace penumbra {
namespace {

struct Surface {
  std::vector<glm::vec3> positions;
  std::vector<glm::uvec3> triangles;
  std::vector<uint32_t> materials;
  std::vector<SurfaceFace> faces;
};

Surface fromScene(const Scene& scene, bool two_sided) {
  const FlatTriangles flat = flattenScene(scene);
  Surface s{flat.positions, flat.triangles, flat.material_ids, {}};
  for (uint32_t t = 0; t < s.triangles.size(); ++t) {
    s.faces.push_back({t, false});
    if (two_sided) s.faces.push_back({t, true});
  }
  return s;
}

Surface quad(glm::vec3 o, glm::vec3 u, glm::vec3 v, bool two_sided) {
  Surface s;
  s.positions = {o, o + u, o + u + v, o + v};
  s.triangles = {{0, 1, 2}, {0, 2, 3}};
  s.materials = {0, 0};
  for (uint32_t t = 0; t < 2; ++t) {
    s.faces.push_back({t, false});
    if (two_sided) s.faces.push_back({t, true});
  }
  return s;
}

double faceArea(const Surface& s, size_t f) {
  const glm::uvec3 t = s.triangles[s.faces[f].triangle];
  return 0.5 * glm::length(glm::cross(glm::dvec3(s.positions[t.y] - s.positions[t.x]),
                                      glm::dvec3(s.positions[t.z] - s.positions[t.x])));
}

ChartAtlas build(const Surface& s, const ChartAtlasOptions& o) {
  Expected<ChartAtlas> a = buildChartAtlas(s.positions, s.triangles, s.materials, s.faces, o);
  EXPECT_TRUE(a.ok()) << (a.ok() ? "" : a.error().message);
  return a.ok() ? std::move(*a) : ChartAtlas();
}

// Every face is covered exactly once: its pieces over all elements sum to its area, and the
// elements' areas sum to the surface's.
void expectExactCover(const Surface& s, const ChartAtlas& a) {
  std::vector<double> covered(s.faces.size(), 0.0);
  double element_total = 0.0;
  for (size_t e = 0; e < a.elementCount(); ++e) {
    const glm::ivec2 t = a.texelOf(e);
    const std::span<const uint32_t> faces(a.element_faces.data() + a.element_face_first[e],
                                          a.element_face_first[e + 1] - a.element_face_first[e]);
    const double area =
        a.forEachPiece(t, t, faces, s.positions, s.triangles,
                       [&](uint32_t f, const std::array<glm::dvec3, 8>&, int, double piece) {
                         covered[f] += piece;
                         EXPECT_EQ(a.charts.face_chart[f], int32_t(a.element_chart[e]));
                       });
    EXPECT_NEAR(area, a.element_area[e], 1e-6 * area + 1e-15);
    element_total += a.element_area[e];
  }
  double total = 0.0;
  for (size_t f = 0; f < s.faces.size(); ++f) {
    const double area = faceArea(s, f);
    total += area;
    EXPECT_NEAR(covered[f], area, 1e-6 * area + 1e-12) << "face " << f;
  }
  EXPECT_NEAR(element_total, total, 1e-9 * total);
}

// A bilinear lookup at points all over each face reads (with non-zero weight) only texels of the
// face's own chart, never empty or dilated ones.
void expectNoBleeding(const Surface& s, const ChartAtlas& a, int samples_per_edge) {
  for (size_t f = 0; f < s.faces.size(); ++f) {
    const int32_t chart = a.charts.face_chart[f];
    if (chart < 0) continue;
    const glm::vec2 c0(a.corner_texel[3 * f]), c1(a.corner_texel[3 * f + 1]),
        c2(a.corner_texel[3 * f + 2]);
    for (int i = 0; i <= samples_per_edge; ++i) {
      for (int j = 0; i + j <= samples_per_edge; ++j) {
        const float w1 = float(i) / float(samples_per_edge),
                    w2 = float(j) / float(samples_per_edge);
        const glm::vec2 p = c0 + w1 * (c1 - c0) + w2 * (c2 - c0);
        const glm::vec2 q = p - 0.5f;
        const int x0 = int(std::floor(q.x)), y0 = int(std::floor(q.y));
        const float fx = q.x - float(x0), fy = q.y - float(y0);
        for (int dy = 0; dy < 2; ++dy) {
          for (int dx = 0; dx < 2; ++dx) {
            const float w = (dx ? fx : 1.0f - fx) * (dy ? fy : 1.0f - fy);
            if (w <= 1e-4f) continue;
            const int x = x0 + dx, y = y0 + dy;
            ASSERT_TRUE(x >= 0 && y >= 0 && x < a.width && y < a.height);
            const size_t t = a.texelIndex(x, y);
            ASSERT_EQ(a.texel_chart[t], chart) << "face " << f << " texel " << x << "," << y;
            ASSERT_TRUE(a.texel_kind[t] == AtlasTexelKind::kInside ||
                        a.texel_kind[t] == AtlasTexelKind::kBorder);
          }
        }
      }
    }
  }
}

TEST(ChartAtlas, WallGetsTheTexelsItsAreaDeserves) {
  // A 4 m x 3 m wall of two triangles at 10 texels per metre: one planar chart of exactly
  // 40 x 30 elements of 1 cm^2 each, whatever the triangle count.
  const Surface s = quad({0, 0, 0}, {4, 0, 0}, {0, 3, 0}, false);
  ChartAtlasOptions o;
  o.texel_density = 10.0;
  const ChartAtlas a = build(s, o);
  ASSERT_EQ(a.chartCount(), 1u);
  EXPECT_TRUE(a.charts.charts[0].planar);
  EXPECT_EQ(a.elementCount(), 1200u);
  for (size_t e = 0; e < a.elementCount(); ++e) {
    EXPECT_NEAR(a.element_area[e], 0.01, 1e-9);
    EXPECT_NEAR(a.element_normal[e].z, 1.0, 1e-12);
  }
  const ChartAtlasQuality q = measureChartAtlas(a, s.positions, s.triangles);
  EXPECT_NEAR(q.max_stretch, 1.0, 1e-6);
  // 40 x 30 elements, a ring of border texels and the padding: 1200 of 44 x 36 texels.
  EXPECT_GE(q.utilisation, 0.75) << a.width << " x " << a.height;
  expectExactCover(s, a);
  expectNoBleeding(s, a, 40);
}

TEST(ChartAtlas, TwoSidedSurfacesGetElementsOnBothSides) {
  const Surface s = quad({0, 0, 0}, {2, 0, 0}, {0, 1, 0}, true);
  ChartAtlasOptions o;
  o.texel_density = 8.0;
  const ChartAtlas a = build(s, o);
  ASSERT_EQ(a.chartCount(), 2u);
  EXPECT_EQ(a.elementCount(), 2u * 16u * 8u);
  double front = 0.0, back = 0.0;
  for (size_t e = 0; e < a.elementCount(); ++e) {
    (a.element_normal[e].z > 0.0 ? front : back) += a.element_area[e];
    EXPECT_NEAR(std::abs(a.element_normal[e].z), 1.0, 1e-12);
  }
  EXPECT_NEAR(front, 2.0, 1e-9);
  EXPECT_NEAR(back, 2.0, 1e-9);
  expectExactCover(s, a);
  expectNoBleeding(s, a, 16);
}

TEST(ChartAtlas, CubeHasOneChartPerSideAndMaterialsSplitCharts) {
  Scene cube = loadScene("cornell").value();  // boxes: flat faces with 90-degree creases
  Surface s = fromScene(cube, false);
  ChartAtlasOptions o;
  o.texel_density = 60.0;
  const ChartAtlas a = build(s, o);
  // Every chart is planar and single-material.
  for (const Chart& c : a.charts.charts) {
    EXPECT_TRUE(c.planar);
    for (uint32_t f : c.faces) {
      EXPECT_EQ(s.materials[s.faces[f].triangle], s.materials[s.faces[c.faces[0]].triangle]);
      EXPECT_GT(
          glm::dot(c.normal, glm::dvec3(glm::cross(
                                 s.positions[s.triangles[f].y] - s.positions[s.triangles[f].x],
                                 s.positions[s.triangles[f].z] - s.positions[s.triangles[f].x]))),
          0.0);
    }
  }
  expectExactCover(s, a);
  expectNoBleeding(s, a, 12);
}

void checkRealMesh(const std::string& scene_path, double density, size_t max_charts) {
  Expected<Scene> scene = loadScene(scene_path);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  const Surface s = fromScene(*scene, false);
  ChartAtlasOptions o;
  o.texel_density = density;
  const ChartAtlas a = build(s, o);
  const ChartAtlasQuality q = measureChartAtlas(a, s.positions, s.triangles);
  std::printf(
      "%s at %.0f texels/m: %zu faces, %zu charts (%zu planar, %zu conformal), %zu "
      "elements in %d x %d, utilisation %.1f%%, stretch max %.3f mean %.4f\n",
      scene_path.c_str(), density, s.faces.size(), q.charts, q.planar_charts, q.conformal_charts,
      q.elements, a.width, a.height, 100.0 * q.utilisation, q.max_stretch, q.mean_stretch);
  EXPECT_LE(q.charts, max_charts);
  EXPECT_GE(q.utilisation, 0.60);
  EXPECT_LE(q.max_stretch, 4.0);
  EXPECT_LE(q.mean_stretch, 1.1);
  expectExactCover(s, a);
  expectNoBleeding(s, a, 3);
}

TEST(ChartAtlas, BunnyScanPacksWithoutOverlapAndHighUtilisation) {
  // The 69,451-triangle scan, 0.16 m across, at 1500 texels per metre (about 85k elements):
  // far fewer elements than triangles' worth of minimum charts.
  checkRealMesh(test::dataPath("bunny.ply"), 1500.0, 2000);
}

TEST(ChartAtlas, TeapotsScenePacksWithHighUtilisation) {
  checkRealMesh(std::string(PENUMBRA_TEST_DATA) + "/../../scenes/teapots.json", 300.0, 2000);
}

TEST(ChartAtlas, ResolutionPicksTheLargestDensityThatFits) {
  Expected<Scene> scene = loadScene(test::dataPath("teapot.ply"));
  ASSERT_TRUE(scene.ok());
  const Surface s = fromScene(*scene, false);
  ChartAtlasOptions o;
  o.resolution = 256;
  const ChartAtlas a = build(s, o);
  EXPECT_EQ(a.width, 256);
  EXPECT_EQ(a.height, 256);
  const ChartAtlasQuality q = measureChartAtlas(a, s.positions, s.triangles);
  EXPECT_GE(q.utilisation, 0.5);
  // 5% more density does not fit.
  o.resolution = 0;
  o.texel_density = a.texel_density * 1.05;
  const ChartAtlas bigger = build(s, o);
  EXPECT_TRUE(bigger.width > 256 || bigger.height > 256);
  expectExactCover(s, a);
}

TEST(ChartAtlas, AbsurdDensityIsRefusedWithTheSize) {
  const Surface s = quad({0, 0, 0}, {4, 0, 0}, {0, 3, 0}, false);
  ChartAtlasOptions o;
  o.texel_density = 1e6;
  Expected<ChartAtlas> a = buildChartAtlas(s.positions, s.triangles, s.materials, s.faces, o);
  ASSERT_FALSE(a.ok());
  EXPECT_NE(a.error().message.find("texels"), std::string::npos) << a.error().message;
}

}  // namespace
}  // namespace penumbra
