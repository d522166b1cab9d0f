// Triangle meshes in world space (metres). Loaders fan-triangulate polygons and keep the file's
// order, so triangle i of a mesh is the i-th triangle the file describes.
#pragma once

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace penumbra {

struct Mesh {
  std::string name;
  std::vector<glm::vec3> positions;  // metres
  std::vector<glm::vec3> normals;    // empty, or one unit shading normal per position
  std::vector<glm::vec2> uvs;        // empty, or one per position
  // The UVs' v axis: false (OBJ, PLY, JSON) v grows up the image, its origin at the bottom-left;
  // true (glTF) v grows down from the top-left. Images are looked up accordingly.
  bool uv_origin_top = false;
  std::vector<glm::uvec3> triangles;   // indices into positions; front face counter-clockwise
  std::vector<uint32_t> material_ids;  // one per triangle, index into Scene::materials

  size_t triangleCount() const { return triangles.size(); }
};

}  // namespace penumbra
