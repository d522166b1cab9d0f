// Triangle meshes in world space (metres). Loaders fan-triangulate polygons and keep the file's
// order, so triangle i of a mesh is the i-th triangle the file describes.
#pragma once

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace penumbra {

// What one triangle of a scene takes in memory once a method runs on it: the mesh (positions,
// normals and UVs shared by about two triangles each), its flattened copy and the ray-tracing
// hierarchy with its build's temporaries. Measured on a sphere scene (docs/algorithms.md,
// "Limits"); loaders plan with it before they build what a file asks for.
inline constexpr uint64_t kSceneBytesPerTriangle = 200;

struct Mesh {
  std::string name;
  std::vector<glm::vec3> positions;  // metres
  std::vector<glm::vec3> normals;    // empty, or one unit shading normal per position
  std::vector<glm::vec2> uvs;        // empty, or one per position (UV set 0, glTF TEXCOORD_0)
  // UV sets 1, 2, ... (glTF TEXCOORD_1 ...): extra_uvs[k] is set k + 1, each empty or one per
  // position.
  std::vector<std::vector<glm::vec2>> extra_uvs;
  // Vertex colours (glTF COLOR_0), linear RGBA in [0, 1]: empty, or one per position. They
  // multiply the material's reflectance and alpha.
  std::vector<glm::vec4> colors;
  // The UVs' v axis: false (OBJ, PLY, JSON) v grows up the image, its origin at the bottom-left;
  // true (glTF) v grows down from the top-left. Images are looked up accordingly.
  bool uv_origin_top = false;
  std::vector<glm::uvec3> triangles;   // indices into positions; front face counter-clockwise
  std::vector<uint32_t> material_ids;  // one per triangle, index into Scene::materials
  // Where a glTF loader took the mesh from: node, mesh and primitive indices of the file, and
  // whether the node mirrors (then each triangle's corners 1 and 2 are swapped from the file's
  // order). -1 for meshes from other sources. Triangle i is the primitive's i-th triangle
  // (strips and fans expanded as glTF 2.0 sec. 3.7.2.1 says), so a writer can add an attribute
  // to the file's own primitive (io/gltf_lightmapped.h).
  // `gltf_instance`: the copy of an EXT_mesh_gpu_instancing node (-1 for a node without it).
  int gltf_node = -1, gltf_mesh = -1, gltf_primitive = -1, gltf_instance = -1;
  bool gltf_mirrored = false;

  size_t triangleCount() const { return triangles.size(); }
  // UV set k (empty when the mesh has none).
  const std::vector<glm::vec2>& uvSet(uint32_t k) const {
    static const std::vector<glm::vec2> kNone;
    if (k == 0) return uvs;
    return k - 1 < extra_uvs.size() ? extra_uvs[k - 1] : kNone;
  }
};

}  // namespace penumbra
