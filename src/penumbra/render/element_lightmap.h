// The atlas display path of Carr, Hall, Hart 2003, sec. 3.1: "in order to smoothly interpolate
// the displayed radiosities, the 1-D radiosity texture B would need to be resampled into a 2-D
// displayed radiosity texture ... an atlas of the scene". Element values are resampled into a
// lightmap atlas of the scene's triangles (geometry/lightmap_atlas.h): every texel's point is
// located in its element, and the element's smooth corner values (Elements::cornerAverage) are
// interpolated there with the point's barycentrics inside the element. Bilinear lookups of the
// result then show the same piecewise-linear field the corner values define.
//
// Also here: the refined element mesh with its per-corner values and both UV sets, as a baked
// output (`penumbra bake` writes it as glTF).
#pragma once

#include "penumbra/core/image.h"
#include "penumbra/geometry/lightmap_atlas.h"
#include "penumbra/radiosity/elements.h"
#include "penumbra/scene/scene.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstdint>
#include <span>
#include <vector>

namespace penumbra {

// Finds the element holding a point given by its scene triangle and barycentrics. It relies on
// the contract of meshElements (radiosity/elements.h): scene triangle t (corners a, b, c) is
// refined regularly k times into m = 2^k rows, its m^2 elements are stored together, and in row
// j (0 <= j < m), column i (0 <= i < m - j) come the element (i, j) = grid points
// (i, j), (i+1, j), (i, j+1) and, when i + j + 1 < m, the element (i+1, j), (i+1, j+1), (i, j+1),
// where grid point (i, j) is a + i/m (b - a) + j/m (c - a). Degenerate scene triangles have no
// elements.
class ElementLocator {
 public:
  explicit ElementLocator(const Elements& elements);

  struct Location {
    int64_t element = -1;     // -1: the scene triangle has no elements
    glm::vec3 weights{0.0f};  // of the element's corners 0, 1, 2 (sum 1)
  };
  // The element is found from the barycentrics clamped to the triangle; the weights are those of
  // the unclamped point, so a point just outside the triangle (the atlas's border texels)
  // extrapolates the element's linear function.
  Location locate(uint32_t scene_triangle, glm::vec2 barycentric) const;
  // Refinement rows m of a scene triangle (0: no elements).
  uint32_t rows(uint32_t scene_triangle) const { return rows_[scene_triangle]; }
  // Element of grid cell (i, j), lower (upper = false) or upper triangle.
  uint32_t element(uint32_t scene_triangle, uint32_t i, uint32_t j, bool upper) const;

 private:
  std::vector<uint32_t> first_;  // per scene triangle: its first element
  std::vector<uint32_t> rows_;   // per scene triangle: m (0 when it has none)
};

// The value of a point from the per-corner values (3 per element, corner k of element e at
// 3 e + k), interpolated in its element; negative results (extrapolation) clamp to 0. Zero for a
// triangle without elements.
glm::vec3 interpolateCornerValues(const ElementLocator& locator,
                                  std::span<const glm::vec3> corner_values, uint32_t scene_triangle,
                                  glm::vec2 barycentric);

// Rasterises corner values into `atlas`, which must have been built over elements.scene's
// triangles: every filled texel gets the value of its point (interpolateCornerValues), empty ones
// 0. For radiosity pass the corner radiance (B / pi, W m^-2 sr^-1): the image is then the
// outgoing radiance of each surface point, in linear RGB.
Image rasterizeElementLightmap(const LightmapAtlas& atlas, const Elements& elements,
                               std::span<const glm::vec3> corner_values);

// The refined element mesh for output: one vertex per (scene triangle, element grid vertex),
// i.e. vertices are shared inside a scene triangle and duplicated across scene triangles (whose
// lightmap charts differ), and duplicated again wherever the corner values of elements sharing
// the vertex differ. Vertices and triangles are grouped by material.
struct BakedMesh {
  std::vector<glm::vec3> positions;  // metres
  std::vector<glm::vec3> normals;    // unit, the element's front face
  std::vector<glm::vec3> values;     // the corner values (e.g. radiance, W m^-2 sr^-1)
  std::vector<glm::vec2> uv0;        // the scene's UVs interpolated (zeros where it has none)
  std::vector<glm::vec2> uv1;        // lightmap UVs
  std::vector<glm::uvec3> triangles;
  bool has_scene_uvs = false;  // whether any scene mesh had UVs
  struct Group {               // the vertices and triangles of one material
    uint32_t material = 0;
    uint32_t first_vertex = 0, vertex_count = 0;
    uint32_t first_triangle = 0, triangle_count = 0;
  };
  std::vector<Group> groups;  // in increasing material order; indices are global
  // Element of each output triangle.
  std::vector<uint32_t> element;
};

BakedMesh buildBakedMesh(const Scene& scene, const Elements& elements, const LightmapAtlas& atlas,
                         std::span<const glm::vec3> corner_values);

}  // namespace penumbra
