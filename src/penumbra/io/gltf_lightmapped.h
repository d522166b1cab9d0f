// A baked lightmap added to a glTF asset without replacing anything in it (docs/algorithms.md,
// "Baked output"; the extension: docs/web-viewer.md, "PENUMBRA_lightmap"):
//   - the document is the input's own JSON: materials, textures, nodes, animations, extras and
//     extensions stay as they are; buffers become one (`bin_uri`), images given by file are
//     embedded in it, so the output directory holds everything it references;
//   - each lightmapped primitive gains a UV set with the lightmap UVs, the first free one but at
//     least TEXCOORD_1 (TEXCOORD_0 is then a copy, as attribute sets are numbered from 0). Its
//     vertices are split where the lightmap's charts cut the surface (a corner gets the vertex of
//     its (original vertex, lightmap UV) pair), every attribute and morph target gathered
//     accordingly; a primitive whose vertices need no split keeps its accessors;
//   - a mesh instanced by several nodes is copied for each further node, since each instance has
//     its own place in the lightmap;
//   - the primitive's material carries the extension PENUMBRA_lightmap: the lightmap texture
//     (RGBM PNG, linear), its UV set, the RGBM scale and the EXR beside it; a material shared by
//     primitives whose lightmap UV sets differ is copied.
// Scenes that are not one glTF file are first written as a glTF document of their own
// (documentFromScene) and take the same path.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/io/asset_files.h"
#include "penumbra/scene/scene.h"

#include <glm/vec2.hpp>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <vector>

namespace penumbra {

// A glTF document: its JSON, the bytes of each buffer and of each image given by a file URI
// (data URIs stay in the JSON; images in buffer views stay in their buffer).
struct GltfDocument {
  std::string path;  // the file, for messages ("" when made from a scene)
  nlohmann::json json;
  std::vector<std::string> buffers;
  std::vector<std::pair<int, std::string>> file_images;  // (image index, bytes)
  // (node, copy) of an EXT_mesh_gpu_instancing node -> the node that now holds the copy.
  std::map<std::pair<int, int>, int> instance_nodes;
};

// Reads a .gltf or .glb file that loadScene has accepted (with the same `policy`), as a plain
// document (io/gltf/gltf_plain.cpp): compressed views and primitives decoded, sparse accessors
// dense, GPU instances as nodes, only the images textures read.
Expected<GltfDocument> readGltfDocument(const std::string& path, const AssetPolicy& policy = {});

// Where a scene triangle sits in a glTF document: node, mesh, primitive and the triangle's index
// among the primitive's triangles; mirrored when the scene swapped its corners 1 and 2.
struct GltfTriangleSource {
  int32_t node = -1, mesh = -1, primitive = -1;
  int32_t instance = -1;  // the EXT_mesh_gpu_instancing copy, -1 for none
  uint32_t triangle = 0;
  bool mirrored = false;
};

// Per triangle of flattenScene(scene), from the glTF loader's records (Mesh::gltf_node ...);
// empty when some mesh did not come from a glTF primitive.
std::vector<GltfTriangleSource> gltfTriangleSources(const Scene& scene);

// The scene as a glTF document: a node and mesh per scene mesh, a primitive per material,
// materials from the scene's (base colour = reflectance, metallic 0, roughness 1, emission as
// emissive factor and KHR_materials_emissive_strength, doubleSided = two_sided), the camera if
// the scene has one. `sources` receives each flattened triangle's place.
GltfDocument documentFromScene(const Scene& scene, std::vector<GltfTriangleSource>& sources);

// The lightmap the materials reference.
struct LightmapReference {
  // File names beside the glTF (percent-encoded where the glTF names them).
  std::string png_uri;  // RGBM, 8 bits per channel, linear
  std::string exr_uri;  // the same, float
  double scale = 1.0;   // irradiance = scale * rgb * a
  int width = 0, height = 0;
};

// Per triangle of flattenScene(scene): its corners' lightmap UVs in the scene's corner order
// (glTF convention, (0, 0) the top-left of the image).
struct TriangleLightmapUvs {
  glm::vec2 uv[3];
};

// Writes `gltf_path` and `bin_uri` beside it: `doc` with the lightmap attached to every primitive
// a triangle of `sources` comes from, `penumbra_extras` as asset.extras.penumbra. Input error
// for what the document holds that this cannot carry (sparse accessors under a lightmapped
// primitive); run-time error when a file cannot be written.
Status writeLightmappedGltf(GltfDocument doc, std::span<const GltfTriangleSource> sources,
                            std::span<const TriangleLightmapUvs> uvs, const LightmapReference& lm,
                            const nlohmann::json& penumbra_extras, const std::string& gltf_path,
                            const std::string& bin_uri);

}  // namespace penumbra
