// The asset's own lightmap UVs (`--lightmap-uv asset`, geometry/asset_charts.h): a box whose
// second UV set lays its six faces out in a 3 x 2 grid keeps that layout in the atlas (one affine
// map for the whole mesh), each face an island of its own chart; UVs that overlap or leave
// [0, 1] are refused naming the mesh.
#include "penumbra/radiosity/radiosity_surface.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/mat2x2.hpp>
#include <glm/matrix.hpp>

#include <set>

namespace penumbra {
namespace {

// A unit box facing out, each face a quad of its own four vertices, its TEXCOORD_1 in cell
// (face % 3, face / 3) of a 3 x 2 grid with a margin; and a floor below it without one.
Scene boxScene(bool overlap = false, bool outside = false) {
  Scene scene;
  scene.source = "box";
  scene.materials.push_back(Material{"grey", glm::vec3(0.5f), glm::vec3(0.0f)});
  scene.materials.back().two_sided = false;
  Mesh box;
  box.name = "crate";
  const glm::vec3 c[8] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                          {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  // Each face counter-clockwise seen from outside.
  const int quads[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                           {3, 7, 6, 2}, {0, 4, 7, 3}, {1, 2, 6, 5}};
  box.extra_uvs.resize(1);
  for (int f = 0; f < 6; ++f) {
    const uint32_t base = uint32_t(box.positions.size());
    const float m = 0.02f, w = 1.0f / 3.0f, h = 0.5f;
    const float u0 = float(f % 3) * w + m, v0 = float(f / 3) * h + m;
    const float u1 = u0 + w - 2 * m, v1 = v0 + h - 2 * m;
    const glm::vec2 uv[4] = {{u0, v0}, {u1, v0}, {u1, v1}, {u0, v1}};
    for (int k = 0; k < 4; ++k) {
      box.positions.push_back(c[quads[f][k]]);
      glm::vec2 t = uv[k];
      if (overlap && f == 1) t = uv[k] - glm::vec2(w * 0.5f, 0.0f);  // onto face 0's cell
      if (outside && f == 5 && k == 2) t.x = 1.25f;
      box.extra_uvs[0].push_back(t);
    }
    box.triangles.push_back({base, base + 1, base + 2});
    box.triangles.push_back({base, base + 2, base + 3});
    box.material_ids.insert(box.material_ids.end(), {0, 0});
  }
  box.uv_origin_top = true;
  scene.meshes.push_back(box);
  Mesh floor;
  floor.name = "floor";
  floor.positions = {{-1, -0.5f, 2}, {2, -0.5f, 2}, {2, -0.5f, -1}, {-1, -0.5f, -1}};
  floor.triangles = {{0, 1, 2}, {0, 2, 3}};
  floor.material_ids = {0, 0};
  scene.meshes.push_back(floor);
  EXPECT_TRUE(validateScene(scene).ok());
  return scene;
}

TEST(AssetCharts, TheArtistsLayoutIsKeptAndEachIslandIsAChart) {
  const Scene scene = boxScene();
  ChartAtlasOptions options;
  options.texel_density = 24.0;
  options.asset_uvs = true;
  Expected<RadiositySurface> s = RadiositySurface::build(scene, options, false);
  ASSERT_TRUE(s.ok()) << s.error().describe();
  const ChartAtlas& atlas = s->atlas;
  // Six islands of the block, each a chart of its own; the floor charted as usual.
  std::set<int32_t> islands;
  for (size_t f = 0; f < atlas.faces.size(); ++f) {
    const uint32_t t = atlas.faces[f].triangle;
    const int32_t c = atlas.charts.face_chart[f];
    ASSERT_GE(c, 0);
    if (t < 12) {
      EXPECT_EQ(atlas.charts.charts[size_t(c)].asset_block, 0);
      islands.insert(c);
    } else {
      EXPECT_EQ(atlas.charts.charts[size_t(c)].asset_block, -1);
    }
  }
  EXPECT_EQ(islands.size(), 6u);
  // One affine map takes every corner's TEXCOORD_1 to its atlas UV (the block placed whole,
  // perhaps turned): fitted on face 0's first triangle, checked on all 36 corners.
  const auto uv1 = [&](uint32_t t, int k) {
    return glm::dvec2(scene.meshes[0].extra_uvs[0][scene.meshes[0].triangles[t][k]]);
  };
  const auto atlasUv = [&](size_t f, int k) { return glm::dvec2(atlas.uvs[3 * f + size_t(k)]); };
  size_t f0 = 0;
  while (atlas.faces[f0].triangle != 0 || atlas.faces[f0].back) ++f0;
  const glm::dvec2 a0 = uv1(0, 0), a1 = uv1(0, 1), a2 = uv1(0, 2);
  const glm::dvec2 b0 = atlasUv(f0, 0), b1 = atlasUv(f0, 1), b2 = atlasUv(f0, 2);
  const glm::dmat2 from(a1 - a0, a2 - a0), to(b1 - b0, b2 - b0);
  const glm::dmat2 map = to * glm::inverse(from);
  double worst = 0.0;
  for (size_t f = 0; f < atlas.faces.size(); ++f) {
    const uint32_t t = atlas.faces[f].triangle;
    if (t >= 12 || atlas.faces[f].back) continue;
    for (int k = 0; k < 3; ++k) {
      const glm::dvec2 want = b0 + map * (uv1(t, k) - a0);
      worst = std::max(worst, glm::length(want - atlasUv(f, k)) * double(atlas.width));
    }
  }
  EXPECT_LT(worst, 1e-3);  // in texels
  // The texels the block gets: its area at the density (a 1 m^2 face, 24 x 24 texels).
  const double scale = std::sqrt(std::abs(glm::determinant(map)) * atlas.width * atlas.height);
  EXPECT_NEAR(scale / std::sqrt(6.0 / (6.0 * (1.0 / 3.0 - 0.04) * (0.5 - 0.04))), 24.0, 0.01);
  // Every island owns texels, and its elements' areas sum to its face's.
  std::vector<double> area(atlas.charts.charts.size(), 0.0);
  for (size_t e = 0; e < atlas.elementCount(); ++e)
    area[atlas.element_chart[e]] += atlas.element_area[e];
  for (int32_t c : islands) EXPECT_NEAR(area[size_t(c)], 1.0, 1e-6);
}

TEST(AssetCharts, OverlappingOrOutOfRangeUvsAreRefusedNamingTheMesh) {
  ChartAtlasOptions options;
  options.texel_density = 24.0;
  options.asset_uvs = true;
  Expected<RadiositySurface> overlap = RadiositySurface::build(boxScene(true), options, false);
  ASSERT_FALSE(overlap.ok());
  EXPECT_NE(overlap.error().describe().find("crate"), std::string::npos)
      << overlap.error().describe();
  EXPECT_NE(overlap.error().describe().find("overlap"), std::string::npos);
  Expected<RadiositySurface> outside =
      RadiositySurface::build(boxScene(false, true), options, false);
  ASSERT_FALSE(outside.ok());
  EXPECT_NE(outside.error().describe().find("crate"), std::string::npos);
  EXPECT_NE(outside.error().describe().find("outside [0, 1]"), std::string::npos)
      << outside.error().describe();
  // Without asset UVs the same scene builds (the layout is generated).
  options.asset_uvs = false;
  EXPECT_TRUE(RadiositySurface::build(boxScene(true), options, false).ok());
}

}  // namespace
}  // namespace penumbra
