// The atlas display path (Carr, Hall, Hart 2003, sec. 3.1): element values resampled into the
// lightmap reproduce a linear field and a constant one exactly (gutters included), and the baked
// mesh carries the corner values it was given.
#include "penumbra/render/element_lightmap.h"
#include "penumbra/core/check.h"
#include "penumbra/core/rng.h"
#include "penumbra/geometry/lightmap_atlas.h"
#include "penumbra/scene/builtin.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

namespace penumbra {
namespace {

struct Fixture {
  Scene scene;
  Elements elements;
  LightmapAtlas atlas;
};

Fixture cornell(uint32_t target_elements, int lightmap_size) {
  Fixture f;
  Expected<Scene> s = builtinScene("cornell");
  PENUMBRA_CHECK(s.ok());
  f.scene = std::move(*s);
  MeshingOptions mo;
  mo.target_elements = target_elements;
  Expected<Elements> e = meshElements(f.scene, mo);
  PENUMBRA_CHECK(e.ok());
  f.elements = std::move(*e);
  AtlasOptions ao;
  ao.resolution = lightmap_size;
  Expected<LightmapAtlas> a =
      buildLightmapAtlas(f.elements.scene.positions, f.elements.scene.triangles, ao);
  PENUMBRA_CHECK(a.ok());
  f.atlas = std::move(*a);
  return f;
}

// Barycentrics (w1, w2) of p in scene triangle t.
glm::vec2 barycentricOf(const FlatTriangles& flat, uint32_t t, glm::vec3 p) {
  const glm::uvec3 tri = flat.triangles[t];
  const glm::dvec3 a = flat.positions[tri.x], v0 = glm::dvec3(flat.positions[tri.y]) - a,
                   v1 = glm::dvec3(flat.positions[tri.z]) - a, v2 = glm::dvec3(p) - a;
  const double d00 = glm::dot(v0, v0), d01 = glm::dot(v0, v1), d11 = glm::dot(v1, v1);
  const double d20 = glm::dot(v2, v0), d21 = glm::dot(v2, v1);
  const double den = d00 * d11 - d01 * d01;
  return glm::vec2(float((d11 * d20 - d01 * d21) / den), float((d00 * d21 - d01 * d20) / den));
}

glm::vec3 pointOf(const FlatTriangles& flat, uint32_t t, glm::vec2 b) {
  const glm::uvec3 tri = flat.triangles[t];
  return flat.positions[tri.x] * (1.0f - b.x - b.y) + flat.positions[tri.y] * b.x +
         flat.positions[tri.z] * b.y;
}

// A linear RGB field over world space, positive over the Cornell box.
glm::vec3 linearField(glm::vec3 p) {
  return glm::vec3(1.0f + 2.0f * p.x, 2.0f - 1.5f * p.y + 0.5f * p.z, 0.5f + p.x + p.y + p.z);
}

glm::vec3 bilinear(const Image& image, glm::vec2 uv) {
  const float fx = uv.x * float(image.width) - 0.5f, fy = uv.y * float(image.height) - 0.5f;
  const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
  const float ax = fx - float(x0), ay = fy - float(y0);
  auto at = [&](int x, int y) {
    x = std::clamp(x, 0, image.width - 1);
    y = std::clamp(y, 0, image.height - 1);
    return image.at(x, y);
  };
  return (at(x0, y0) * (1 - ax) + at(x0 + 1, y0) * ax) * (1 - ay) +
         (at(x0, y0 + 1) * (1 - ax) + at(x0 + 1, y0 + 1) * ax) * ay;
}

TEST(ElementLightmap, LocatorFindsEveryElementFromItsCentroid) {
  const Fixture f = cornell(300, 256);
  const ElementLocator locator(f.elements);
  for (size_t e = 0; e < f.elements.size(); ++e) {
    const uint32_t t = f.elements.source[e];
    const glm::vec2 b = barycentricOf(f.elements.scene, t, f.elements.centroid[e]);
    const ElementLocator::Location loc = locator.locate(t, b);
    ASSERT_EQ(loc.element, int64_t(e));
    EXPECT_NEAR(loc.weights.x, 1.0f / 3.0f, 1e-4f);
    EXPECT_NEAR(loc.weights.y, 1.0f / 3.0f, 1e-4f);
    EXPECT_NEAR(loc.weights.z, 1.0f / 3.0f, 1e-4f);
  }
}

TEST(ElementLightmap, ReproducesALinearRadiosityField) {
  // Corner values sampled from a linear field: the lightmap holds the field at every texel's
  // point (extrapolated on the border row), and bilinear lookups return it anywhere.
  const Fixture f = cornell(300, 512);
  std::vector<glm::vec3> corners(3 * f.elements.size());
  for (size_t e = 0; e < f.elements.size(); ++e) {
    for (int k = 0; k < 3; ++k) {
      corners[3 * e + size_t(k)] = linearField(f.elements.positions[f.elements.triangles[e][k]]);
    }
  }
  const Image lightmap = rasterizeElementLightmap(f.atlas, f.elements, corners);
  ASSERT_EQ(lightmap.width, f.atlas.width);
  double worst_texel = 0.0;
  for (size_t i = 0; i < lightmap.pixels.size(); ++i) {
    const int32_t t = f.atlas.texel_triangle[i];
    if (t < 0) {
      EXPECT_EQ(lightmap.pixels[i], glm::vec3(0.0f));
      continue;
    }
    if (f.atlas.texel_kind[i] == AtlasTexelKind::kDilated) continue;
    const glm::vec3 expected =
        linearField(pointOf(f.elements.scene, uint32_t(t), f.atlas.texel_barycentric[i]));
    worst_texel = std::max(worst_texel, double(glm::length(lightmap.pixels[i] - expected)));
  }
  EXPECT_LT(worst_texel, 1e-4);
  Rng rng(3, 0);
  double worst_lookup = 0.0;
  for (uint32_t t = 0; t < f.elements.scene.triangles.size(); ++t) {
    for (int sample = 0; sample < 100; ++sample) {
      float u = rng.uniform(), v = rng.uniform();
      if (u + v > 1.0f) u = 1.0f - u, v = 1.0f - v;
      const glm::vec2 b(u, v);
      const glm::vec3 got = bilinear(lightmap, f.atlas.uv(t, b));
      worst_lookup = std::max(
          worst_lookup, double(glm::length(got - linearField(pointOf(f.elements.scene, t, b)))));
    }
  }
  EXPECT_LT(worst_lookup, 1e-4);
}

TEST(ElementLightmap, ConstantRadiosityGivesAConstantLightmapIncludingGutters) {
  const Fixture f = cornell(200, 256);
  const glm::vec3 c(0.25f, 1.5f, 7.0f);
  const std::vector<glm::vec3> corners(3 * f.elements.size(), c);
  const Image lightmap = rasterizeElementLightmap(f.atlas, f.elements, corners);
  size_t border = 0, dilated = 0;
  for (size_t i = 0; i < lightmap.pixels.size(); ++i) {
    if (f.atlas.texel_kind[i] == AtlasTexelKind::kEmpty) {
      EXPECT_EQ(lightmap.pixels[i], glm::vec3(0.0f));
      continue;
    }
    border += f.atlas.texel_kind[i] == AtlasTexelKind::kBorder;
    dilated += f.atlas.texel_kind[i] == AtlasTexelKind::kDilated;
    ASSERT_NEAR(lightmap.pixels[i].x, c.x, 1e-6f) << i;
    ASSERT_NEAR(lightmap.pixels[i].y, c.y, 1e-5f) << i;
    ASSERT_NEAR(lightmap.pixels[i].z, c.z, 1e-5f) << i;
  }
  EXPECT_GT(border, 0u);
  EXPECT_GT(dilated, 0u);
}

TEST(ElementLightmap, BakedMeshCarriesTheCornerValuesAndBothUvSets) {
  const Fixture f = cornell(300, 256);
  std::vector<glm::vec3> corners(3 * f.elements.size());
  for (size_t i = 0; i < corners.size(); ++i) corners[i] = glm::vec3(float(i % 97), 1.0f, 2.0f);
  // Smooth values: equal at a grid vertex within a scene triangle (as cornerAverage gives them).
  const std::vector<glm::vec3> smooth =
      f.elements.cornerAverage(std::vector<glm::vec3>(f.elements.centroid));
  size_t vertex_counts[2] = {0, 0};
  for (int which = 0; which < 2; ++which) {
    const std::vector<glm::vec3>& values = which == 0 ? smooth : corners;
    const BakedMesh mesh = buildBakedMesh(f.scene, f.elements, f.atlas, values);
    ASSERT_EQ(mesh.triangles.size(), f.elements.size());
    ASSERT_EQ(mesh.element.size(), f.elements.size());
    EXPECT_FALSE(mesh.has_scene_uvs);
    std::vector<bool> seen(f.elements.size(), false);
    for (size_t t = 0; t < mesh.triangles.size(); ++t) {
      const uint32_t e = mesh.element[t];
      ASSERT_FALSE(seen[e]);
      seen[e] = true;
      const uint32_t source = f.elements.source[e];
      for (int k = 0; k < 3; ++k) {
        const uint32_t v = mesh.triangles[t][k];
        EXPECT_EQ(mesh.values[v], values[3 * e + size_t(k)]);
        EXPECT_EQ(mesh.positions[v], f.elements.positions[f.elements.triangles[e][k]]);
        EXPECT_EQ(mesh.normals[v], f.elements.normal[e]);
        const glm::vec2 uv =
            f.atlas.uv(source, barycentricOf(f.elements.scene, source, mesh.positions[v]));
        EXPECT_NEAR(mesh.uv1[v].x, uv.x, 1e-5f);
        EXPECT_NEAR(mesh.uv1[v].y, uv.y, 1e-5f);
      }
    }
    // Groups partition vertices and triangles by material.
    uint32_t vertices = 0, triangles = 0;
    for (const BakedMesh::Group& g : mesh.groups) {
      EXPECT_EQ(g.first_vertex, vertices);
      EXPECT_EQ(g.first_triangle, triangles);
      vertices += g.vertex_count;
      triangles += g.triangle_count;
      for (uint32_t t = g.first_triangle; t < g.first_triangle + g.triangle_count; ++t) {
        EXPECT_EQ(f.elements.material[mesh.element[t]], g.material);
        for (int k = 0; k < 3; ++k) {
          EXPECT_GE(mesh.triangles[t][k], g.first_vertex);
          EXPECT_LT(mesh.triangles[t][k], g.first_vertex + g.vertex_count);
        }
      }
    }
    EXPECT_EQ(vertices, mesh.positions.size());
    EXPECT_EQ(triangles, mesh.triangles.size());
    vertex_counts[which] = mesh.positions.size();
  }
  // Smooth values share vertices inside scene triangles; arbitrary values split them.
  EXPECT_LT(vertex_counts[0], vertex_counts[1]);
}

}  // namespace
}  // namespace penumbra
