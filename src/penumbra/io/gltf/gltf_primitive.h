// One glTF mesh primitive read into the mesh's own space (glTF 2.0 sec. 3.7.2 "Meshes"): its
// vertex attributes from plain, quantized (KHR_mesh_quantization), sparse, meshopt-compressed or
// Draco-compressed (KHR_draco_mesh_compression) accessors, its morph targets blended with the
// node's or mesh's default weights (sec. 3.7.2.2), its skin's joints and weights kept for the node
// that places it, and its triangles in the file's order (strips and fans expanded, sec.
// 3.7.2.1). Every value is checked: finite positions, normals and UVs, colours in [0, 1],
// indices below the vertex count, counts that agree.
#pragma once

#include "penumbra/core/expected.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>
#include <nlohmann/json_fwd.hpp>

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace penumbra {

class GltfAsset;

struct PrimitiveData {
  int mode = 4;  // 4 triangles, 5 strip, 6 fan (points and lines are not read)
  int64_t material = -1;
  std::vector<glm::dvec3> positions;
  std::vector<glm::dvec3> normals;          // empty or one per position
  std::vector<std::vector<glm::vec2>> uvs;  // TEXCOORD_k at k: empty or one per position
  std::vector<glm::vec4> colors;            // COLOR_0: empty or one per position
  std::vector<glm::uvec4> joints[2];        // JOINTS_0, JOINTS_1
  std::vector<glm::vec4> weights[2];        // WEIGHTS_0, WEIGHTS_1
  std::vector<uint32_t> corners;            // three per triangle
  size_t dropped = 0;                       // vertices past the last whole triangle of a list
  size_t bad_normals = 0;  // NORMAL values that were not finite, read as zero (face normal)
};

// Whether primitive `prim` of a mesh draws triangles (mode 4, 5 or 6).
bool drawsTriangles(const nlohmann::json& prim);

// Reads primitive `primitive` of mesh `mesh`, its morph targets blended with `weights` (the node's
// weights, or the mesh's, or none); `where` names it ("mesh 0 primitive 1").
Expected<PrimitiveData> readPrimitive(GltfAsset& asset, int64_t mesh, size_t primitive,
                                      std::span<const double> weights, const std::string& where);

}  // namespace penumbra
