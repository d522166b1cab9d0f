// The scene's own triangles as a baked output, for solvers whose elements are lightmap texels
// (every radiosity method, on the chart atlas): every face keeps its three corners (not shared
// between faces), its lightmap UVs (TEXCOORD_1) and, per corner, the lightmap's value there. A
// two-sided surface's back face is a triangle of its own, wound the other way, so that each side
// shows its own light in a viewer that culls back faces. The lightmap carries the solution; the
// corner values are its coarse per-vertex fallback (glTF COLOR_0) for viewers that ignore the
// second UV set.
#pragma once

#include "penumbra/core/image.h"
#include "penumbra/geometry/chart_atlas.h"
#include "penumbra/scene/scene.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstdint>
#include <vector>

namespace penumbra {

// A mesh for output, vertices and triangles grouped by material.
struct BakedMesh {
  std::vector<glm::vec3> positions;  // metres
  std::vector<glm::vec3> normals;    // unit, the face's
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
  // The scene triangle of each output triangle (flattenScene order).
  std::vector<uint32_t> element;
};

// `atlas` must have been built over flattenScene(scene)'s triangles and `lightmap` have its size.
// Triangles of zero area are left out. BakedMesh::element holds each output triangle's scene
// triangle (flattenScene order).
BakedMesh buildLightmapMesh(const Scene& scene, const ChartAtlas& atlas, const Image& lightmap);

}  // namespace penumbra
