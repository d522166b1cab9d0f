// The lightmap atlas: every triangle gets a chart, charts never share a texel, chart areas follow
// triangle areas, and a bilinear lookup anywhere inside a triangle reads only that triangle's
// texels, with values that reproduce a linear field exactly.
#include "penumbra/geometry/lightmap_atlas.h"
#include "penumbra/core/rng.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <bit>
#include <cmath>
#include <vector>

namespace penumbra {
namespace {

struct Soup {
  std::vector<glm::vec3> positions;
  std::vector<glm::uvec3> triangles;
};

// Triangles of sizes over three orders of magnitude and all shapes, plus a degenerate one.
Soup randomSoup(int count, uint64_t seed) {
  Rng rng(seed, 0);
  Soup s;
  for (int t = 0; t < count; ++t) {
    const glm::vec3 o = test::randomInBox(rng, -5.0f, 5.0f);
    const float size = 0.01f * std::pow(100.0f, rng.uniform());
    const uint32_t base = uint32_t(s.positions.size());
    s.positions.push_back(o);
    s.positions.push_back(o + size * test::randomDirection(rng));
    s.positions.push_back(o + size * test::randomDirection(rng));
    s.triangles.emplace_back(base, base + 1, base + 2);
  }
  const uint32_t base = uint32_t(s.positions.size());
  s.positions.insert(s.positions.end(), {glm::vec3(0.0f), glm::vec3(1.0f), glm::vec3(2.0f)});
  s.triangles.emplace_back(base, base + 1, base + 2);
  return s;
}

double triangleArea(const Soup& s, size_t t) {
  const glm::dvec3 a = s.positions[s.triangles[t].x], b = s.positions[s.triangles[t].y],
                   c = s.positions[s.triangles[t].z];
  return 0.5 * glm::length(glm::cross(b - a, c - a));
}

glm::vec3 pointOf(const Soup& s, size_t t, glm::vec2 b) {
  const glm::uvec3 tri = s.triangles[t];
  return s.positions[tri.x] * (1.0f - b.x - b.y) + s.positions[tri.y] * b.x +
         s.positions[tri.z] * b.y;
}

// The texels (with their weights) a bilinear lookup at `uv` reads: texel centres at
// (x + 0.5) / width.
struct Tap {
  int x, y;
  float weight;
};
std::vector<Tap> bilinearTaps(const LightmapAtlas& atlas, glm::vec2 uv) {
  const float fx = uv.x * float(atlas.width) - 0.5f, fy = uv.y * float(atlas.height) - 0.5f;
  const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
  const float ax = fx - float(x0), ay = fy - float(y0);
  return {{x0, y0, (1 - ax) * (1 - ay)},
          {x0 + 1, y0, ax * (1 - ay)},
          {x0, y0 + 1, (1 - ax) * ay},
          {x0 + 1, y0 + 1, ax * ay}};
}

// Uniform barycentrics, sometimes on an edge or a corner.
glm::vec2 randomBarycentric(Rng& rng) {
  float u = rng.uniform(), v = rng.uniform();
  if (u + v > 1.0f) u = 1.0f - u, v = 1.0f - v;
  const float kind = rng.uniform();
  if (kind < 0.05f) return glm::vec2(u + v, 0.0f);                        // edge 0-1
  if (kind < 0.10f) return glm::vec2(0.0f, u + v);                        // edge 0-2
  if (kind < 0.15f) return glm::vec2(u, 1.0f - u);                        // edge 1-2
  if (kind < 0.17f) return glm::vec2(float(rng.uniform() < 0.5f), 0.0f);  // corner
  return glm::vec2(u, v);
}

TEST(LightmapAtlas, EveryTriangleGetsItsOwnChartAndChartsDoNotOverlap) {
  const Soup s = randomSoup(400, 1);
  AtlasOptions options;
  options.texel_density = 300.0;
  Expected<LightmapAtlas> atlas = buildLightmapAtlas(s.positions, s.triangles, options);
  ASSERT_TRUE(atlas.ok()) << atlas.error().describe();
  ASSERT_EQ(atlas->charts.size(), s.triangles.size());
  ASSERT_EQ(atlas->uvs.size(), 3 * s.triangles.size());
  EXPECT_TRUE(std::has_single_bit(unsigned(atlas->width)));
  EXPECT_TRUE(std::has_single_bit(unsigned(atlas->height)));

  // Count each triangle's texels by kind: its footprint is all its own.
  std::vector<int> inside(s.triangles.size(), 0), border(s.triangles.size(), 0);
  for (size_t i = 0; i < atlas->texel_kind.size(); ++i) {
    const int32_t t = atlas->texel_triangle[i];
    const AtlasTexelKind kind = atlas->texel_kind[i];
    EXPECT_EQ(t < 0, kind == AtlasTexelKind::kEmpty);
    if (kind == AtlasTexelKind::kInside) ++inside[size_t(t)];
    if (kind == AtlasTexelKind::kBorder) ++border[size_t(t)];
  }
  for (size_t t = 0; t < s.triangles.size(); ++t) {
    const int leg = atlas->charts[t].leg;
    EXPECT_EQ(inside[t], (leg + 1) * (leg + 2) / 2) << "triangle " << t;
    EXPECT_EQ(border[t], leg) << "triangle " << t;
    // Corners sit on texel centres inside the texture, and those texels know their corner.
    for (int k = 0; k < 3; ++k) {
      const glm::vec2 uv = atlas->uvs[3 * t + size_t(k)];
      ASSERT_GT(uv.x, 0.0f);
      ASSERT_LT(uv.x, 1.0f);
      ASSERT_GT(uv.y, 0.0f);
      ASSERT_LT(uv.y, 1.0f);
      const glm::vec2 texel = uv * glm::vec2(atlas->width, atlas->height) - 0.5f;
      EXPECT_FLOAT_EQ(texel.x, std::round(texel.x));
      EXPECT_FLOAT_EQ(texel.y, std::round(texel.y));
      const size_t at = atlas->texelIndex(int(std::round(texel.x)), int(std::round(texel.y)));
      EXPECT_EQ(atlas->texel_triangle[at], int32_t(t));
      const glm::vec2 expected = k == 0   ? glm::vec2(0, 0)
                                 : k == 1 ? glm::vec2(1, 0)
                                          : glm::vec2(0, 1);
      EXPECT_NEAR(atlas->texel_barycentric[at].x, expected.x, 1e-6f);
      EXPECT_NEAR(atlas->texel_barycentric[at].y, expected.y, 1e-6f);
    }
  }
}

TEST(LightmapAtlas, ChartAreasAreProportionalToTriangleAreas) {
  const Soup s = randomSoup(300, 2);
  AtlasOptions options;
  options.texel_density = 500.0;
  Expected<LightmapAtlas> atlas = buildLightmapAtlas(s.positions, s.triangles, options);
  ASSERT_TRUE(atlas.ok()) << atlas.error().describe();
  EXPECT_DOUBLE_EQ(atlas->texel_density, 500.0);
  int checked = 0;
  for (size_t t = 0; t < s.triangles.size(); ++t) {
    const double texels = 0.5 * double(atlas->charts[t].leg) * double(atlas->charts[t].leg);
    const double expected = triangleArea(s, t) * 500.0 * 500.0;
    if (atlas->charts[t].leg < 10) {
      EXPECT_LE(texels, std::max(expected * 1.5, 2.0)) << t;  // small: rounding dominates
      continue;
    }
    EXPECT_NEAR(texels / expected, 1.0, 0.12) << "triangle " << t;
    ++checked;
  }
  EXPECT_GT(checked, 100);
}

TEST(LightmapAtlas, BilinearLookupsInsideATriangleReadOnlyItsTexels) {
  const Soup s = randomSoup(300, 3);
  for (const double density : {40.0, 400.0}) {
    AtlasOptions options;
    options.texel_density = density;
    Expected<LightmapAtlas> atlas = buildLightmapAtlas(s.positions, s.triangles, options);
    ASSERT_TRUE(atlas.ok()) << atlas.error().describe();
    Rng rng(7, 0);
    for (size_t t = 0; t < s.triangles.size(); ++t) {
      for (int sample = 0; sample < 200; ++sample) {
        const glm::vec2 b = randomBarycentric(rng);
        for (const Tap& tap : bilinearTaps(*atlas, atlas->uv(uint32_t(t), b))) {
          if (tap.weight <= 1e-6f) continue;  // float rounding at exact texel centres
          ASSERT_GE(tap.x, 0);
          ASSERT_GE(tap.y, 0);
          ASSERT_LT(tap.x, atlas->width);
          ASSERT_LT(tap.y, atlas->height);
          const size_t at = atlas->texelIndex(tap.x, tap.y);
          ASSERT_EQ(atlas->texel_triangle[at], int32_t(t))
              << "density " << density << " triangle " << t << " b " << b.x << " " << b.y;
          const AtlasTexelKind kind = atlas->texel_kind[at];
          ASSERT_TRUE(kind == AtlasTexelKind::kInside || kind == AtlasTexelKind::kBorder);
        }
      }
    }
  }
}

TEST(LightmapAtlas, BilinearLookupsReproduceALinearFieldExactly) {
  // A field linear in world position, stored at texel centres through their barycentrics
  // (extrapolated on the border row), is what bilinear filtering returns anywhere in a triangle.
  const Soup s = randomSoup(200, 4);
  AtlasOptions options;
  options.resolution = 512;
  Expected<LightmapAtlas> atlas = buildLightmapAtlas(s.positions, s.triangles, options);
  ASSERT_TRUE(atlas.ok()) << atlas.error().describe();
  auto field = [](glm::vec3 p) { return 2.0f + 0.3f * p.x - 0.2f * p.y + 0.1f * p.z; };
  std::vector<float> texels(atlas->texel_kind.size(), 0.0f);
  for (size_t i = 0; i < texels.size(); ++i) {
    const int32_t t = atlas->texel_triangle[i];
    if (t >= 0) texels[i] = field(pointOf(s, size_t(t), atlas->texel_barycentric[i]));
  }
  Rng rng(8, 0);
  double worst = 0.0;
  for (size_t t = 0; t < s.triangles.size(); ++t) {
    if (triangleArea(s, t) == 0.0) continue;
    for (int sample = 0; sample < 50; ++sample) {
      const glm::vec2 b = randomBarycentric(rng);
      double value = 0.0;
      for (const Tap& tap : bilinearTaps(*atlas, atlas->uv(uint32_t(t), b))) {
        if (tap.weight != 0.0f) value += tap.weight * texels[atlas->texelIndex(tap.x, tap.y)];
      }
      worst = std::max(worst, std::abs(value - field(pointOf(s, t, b))));
    }
  }
  EXPECT_LT(worst, 1e-4);
}

TEST(LightmapAtlas, GivenSizeIsFilledWellAndGuttersAreDilated) {
  const Soup s = randomSoup(500, 5);
  AtlasOptions options;
  options.resolution = 1024;
  Expected<LightmapAtlas> atlas = buildLightmapAtlas(s.positions, s.triangles, options);
  ASSERT_TRUE(atlas.ok()) << atlas.error().describe();
  EXPECT_EQ(atlas->width, 1024);
  EXPECT_EQ(atlas->height, 1024);
  EXPECT_GT(atlas->texel_density, 0.0);
  size_t footprint = 0, empty = 0;
  for (size_t i = 0; i < atlas->texel_kind.size(); ++i) {
    footprint += atlas->texel_kind[i] == AtlasTexelKind::kInside ||
                 atlas->texel_kind[i] == AtlasTexelKind::kBorder;
    empty += atlas->texel_kind[i] == AtlasTexelKind::kEmpty;
  }
  EXPECT_GT(double(footprint), 0.25 * 1024.0 * 1024.0);  // the largest density that fits
  // A notch denser does not fit in the same size.
  AtlasOptions denser;
  denser.texel_density = atlas->texel_density * 1.1;
  Expected<LightmapAtlas> more = buildLightmapAtlas(s.positions, s.triangles, denser);
  ASSERT_TRUE(more.ok());
  EXPECT_GT(more->width * more->height, 1024 * 1024);
  // Dilation: no empty texel within `gutter` texels of a footprint.
  const int g = atlas->gutter;
  for (int y = 0; y < atlas->height; ++y) {
    for (int x = 0; x < atlas->width; ++x) {
      const AtlasTexelKind kind = atlas->texel_kind[atlas->texelIndex(x, y)];
      if (kind != AtlasTexelKind::kInside && kind != AtlasTexelKind::kBorder) continue;
      for (int dy = -g; dy <= g; ++dy) {
        for (int dx = -g; dx <= g; ++dx) {
          const int nx = x + dx, ny = y + dy;
          if (nx < 0 || ny < 0 || nx >= atlas->width || ny >= atlas->height) continue;
          ASSERT_NE(atlas->texel_kind[atlas->texelIndex(nx, ny)], AtlasTexelKind::kEmpty)
              << nx << " " << ny;
        }
      }
    }
  }
  EXPECT_GT(empty, 0u);
}

TEST(LightmapAtlas, RefusesWhatCannotFit) {
  const Soup s = randomSoup(3000, 6);
  AtlasOptions tiny;
  tiny.resolution = 64;  // 3000 cells of at least 4 texels plus gutters do not fit
  Expected<LightmapAtlas> a = buildLightmapAtlas(s.positions, s.triangles, tiny);
  EXPECT_TRUE(test::errorNames(a, "", "--lightmap-size"));
  AtlasOptions dense;
  dense.texel_density = 1e6;
  Expected<LightmapAtlas> b = buildLightmapAtlas(s.positions, s.triangles, dense);
  EXPECT_TRUE(test::errorNames(b, "", "--texel-density"));
  Expected<LightmapAtlas> c = buildLightmapAtlas(s.positions, {}, AtlasOptions{});
  EXPECT_FALSE(c.ok());
}

TEST(LightmapAtlas, ClampBarycentricGivesAPointOnTheTriangle) {
  EXPECT_EQ(clampBarycentric(glm::vec2(0.2f, 0.3f)), glm::vec2(0.2f, 0.3f));
  const glm::vec2 a = clampBarycentric(glm::vec2(0.6f, 0.6f));  // w0 = -0.2
  EXPECT_FLOAT_EQ(a.x, 0.5f);
  EXPECT_FLOAT_EQ(a.y, 0.5f);
  const glm::vec2 b = clampBarycentric(glm::vec2(-0.1f, 0.5f));
  EXPECT_FLOAT_EQ(b.x, 0.0f);
  EXPECT_NEAR(b.y, 0.5f / 1.1f, 1e-6f);
}

}  // namespace
}  // namespace penumbra
