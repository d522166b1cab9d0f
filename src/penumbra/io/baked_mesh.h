// A mesh as a bake writes it (render/lightmap_mesh.h builds it; io/gltf_writer.h writes it).
#pragma once

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

}  // namespace penumbra
