#include "penumbra/io/gltf_writer.h"

#include "penumbra/io/asset_files.h"

#include "penumbra/core/check.h"
#include "penumbra/core/file_util.h"

#include <glm/common.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <exception>
#include <filesystem>
#include <limits>
#include <vector>

namespace penumbra {

namespace {

using json = nlohmann::json;

// glTF 2.0 enums (sec. 3.6.2, 3.7.2, 3.8.3).
constexpr int kFloat = 5126, kUnsignedInt = 5125;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;
constexpr int kLinear = 9729, kClampToEdge = 33071;

// Appends raw bytes to the buffer, 4-byte aligned, and returns their offset.
size_t append(std::string& data, const void* bytes, size_t size) {
  while (data.size() % 4 != 0) data.push_back('\0');
  const size_t offset = data.size();
  data.append(static_cast<const char*>(bytes), size);
  return offset;
}

int addView(json& doc, size_t offset, size_t length, size_t stride, int target) {
  json view = {{"buffer", 0}, {"byteOffset", offset}, {"byteLength", length}, {"target", target}};
  if (stride > 0) view["byteStride"] = stride;
  doc["bufferViews"].push_back(std::move(view));
  return int(doc["bufferViews"].size()) - 1;
}

int addAccessor(json& doc, int view, size_t byte_offset, size_t count, const char* type,
                int component_type) {
  doc["accessors"].push_back({{"bufferView", view},
                              {"byteOffset", byte_offset},
                              {"count", count},
                              {"type", type},
                              {"componentType", component_type}});
  return int(doc["accessors"].size()) - 1;
}

// COLOR_0: the radiance times color_0_scale, clamped to [0, 1].
std::vector<glm::vec3> bakedColors(const BakedMesh& mesh, float color_0_scale) {
  std::vector<glm::vec3> colors(mesh.positions.size());
  for (size_t v = 0; v < colors.size(); ++v) {
    colors[v] = glm::clamp(mesh.values[v] * color_0_scale, 0.0f, 1.0f);
  }
  return colors;
}

// One vertex attribute: `stride` bytes a vertex from `data`, in its buffer view `view`.
struct Attribute {
  const char* name;
  const void* data;
  size_t stride;
  const char* type;
  int view = -1;
};

// The attributes in buffer order; `colors` (bakedColors) must outlive them.
std::array<Attribute, 6> bakedAttributes(const BakedMesh& mesh,
                                         const std::vector<glm::vec3>& colors) {
  const std::vector<glm::vec2>& uv0 = mesh.has_scene_uvs ? mesh.uv0 : mesh.uv1;
  const size_t v3 = sizeof(glm::vec3), v2 = sizeof(glm::vec2);
  return {{
      {"POSITION", mesh.positions.data(), v3, "VEC3"},
      {"NORMAL", mesh.normals.data(), v3, "VEC3"},
      {"TEXCOORD_0", uv0.data(), v2, "VEC2"},
      {"TEXCOORD_1", mesh.uv1.data(), v2, "VEC2"},
      {"COLOR_0", colors.data(), v3, "VEC3"},
      {"_RADIANCE", mesh.values.data(), v3, "VEC3"},
  }};
}

// The buffer: attributes one after another (tightly packed), then the indices, local to each
// primitive's vertices. Sets each attribute's view; returns the indices' view.
int addBakedBuffer(json& doc, const BakedMesh& mesh, std::string& bin,
                   std::array<Attribute, 6>& attributes) {
  const size_t nv = mesh.positions.size();
  std::vector<uint32_t> indices(3 * mesh.triangles.size());
  for (const BakedMesh::Group& g : mesh.groups) {
    for (uint32_t t = g.first_triangle; t < g.first_triangle + g.triangle_count; ++t) {
      for (int k = 0; k < 3; ++k) {
        indices[3 * size_t(t) + size_t(k)] = mesh.triangles[t][k] - g.first_vertex;
      }
    }
  }
  for (Attribute& a : attributes) {
    const size_t offset = append(bin, a.data, a.stride * nv);
    a.view = addView(doc, offset, a.stride * nv, a.stride, kArrayBuffer);
  }
  const size_t bytes = indices.size() * sizeof(uint32_t);
  return addView(doc, append(bin, indices.data(), bytes), bytes, 0, kElementArrayBuffer);
}

// The mesh: a primitive per group, with its accessors into the attributes' and indices' views.
json bakedPrimitives(json& doc, const BakedMesh& mesh, const std::string& name,
                     const std::array<Attribute, 6>& attributes, int index_view) {
  json primitives = json::array();
  for (const BakedMesh::Group& g : mesh.groups) {
    json p = {{"mode", 4}, {"material", g.material}, {"attributes", json::object()}};
    for (const Attribute& a : attributes) {
      p["attributes"][a.name] = addAccessor(doc, a.view, size_t(g.first_vertex) * a.stride,
                                            g.vertex_count, a.type, kFloat);
    }
    // POSITION needs its bounds.
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    for (uint32_t v = g.first_vertex; v < g.first_vertex + g.vertex_count; ++v) {
      lo = glm::min(lo, mesh.positions[v]);
      hi = glm::max(hi, mesh.positions[v]);
    }
    json& position = doc["accessors"][p["attributes"]["POSITION"].get<size_t>()];
    position["min"] = {lo.x, lo.y, lo.z};
    position["max"] = {hi.x, hi.y, hi.z};
    p["indices"] = addAccessor(doc, index_view, size_t(g.first_triangle) * 3 * sizeof(uint32_t),
                               size_t(g.triangle_count) * 3, "SCALAR", kUnsignedInt);
    primitives.push_back(std::move(p));
  }
  return {{"name", name}, {"primitives", std::move(primitives)}};
}

// A scene material as glTF: black, emitting the lightmap (texture 0 on texCoord 1); its
// reflectance and emission in extras.penumbra.
json bakedMaterial(const Material& m) {
  return {{"name", m.name},
          {"pbrMetallicRoughness",
           {{"baseColorFactor", {0.0, 0.0, 0.0, 1.0}},
            {"metallicFactor", 0.0},
            {"roughnessFactor", 1.0}}},
          {"emissiveFactor", {1.0, 1.0, 1.0}},
          {"emissiveTexture", {{"index", 0}, {"texCoord", 1}}},
          {"extras",
           {{"penumbra",
             {{"reflectance", {m.reflectance.x, m.reflectance.y, m.reflectance.z}},
              {"emission", {m.emission.x, m.emission.y, m.emission.z}}}}}}};
}

// The document around the mesh: the asset (version, generator, extras.penumbra with the caller's
// extras and color_0_scale), the lightmap's image, sampler (linear without mipmaps, whose coarse
// levels would mix charts; clamped) and texture, the materials, one node in the default scene.
void describeDocument(json& doc, std::span<const Material> materials, const BakedGltfInfo& info) {
  json extras = info.extras;
  extras["color_0_scale"] = info.color_0_scale;
  doc["asset"] = {
      {"version", "2.0"}, {"generator", "penumbra 0.1.0"}, {"extras", {{"penumbra", extras}}}};
  doc["images"] = {{{"name", "lightmap"},
                    {"uri", percentEncodePath(info.lightmap_uri)},
                    {"mimeType", "image/png"}}};
  doc["samplers"] = {{{"magFilter", kLinear},
                      {"minFilter", kLinear},
                      {"wrapS", kClampToEdge},
                      {"wrapT", kClampToEdge}}};
  doc["textures"] = {{{"name", "lightmap"}, {"source", 0}, {"sampler", 0}}};
  doc["materials"] = json::array();
  for (const Material& m : materials) doc["materials"].push_back(bakedMaterial(m));
  doc["nodes"] = {{{"name", info.name}, {"mesh", 0}}};
  doc["scenes"] = {{{"name", info.name}, {"nodes", {0}}}};
  doc["scene"] = 0;
}

}  // namespace

Status writeBakedGltf(const std::string& gltf_path, const BakedMesh& mesh,
                      std::span<const Material> materials, const BakedGltfInfo& info) {
  const size_t nv = mesh.positions.size();
  PENUMBRA_CHECK(mesh.normals.size() == nv && mesh.values.size() == nv && mesh.uv0.size() == nv &&
                 mesh.uv1.size() == nv);
  namespace fs = std::filesystem;
  try {
    json doc = {{"bufferViews", json::array()}, {"accessors", json::array()}};
    describeDocument(doc, materials, info);
    const std::vector<glm::vec3> colors = bakedColors(mesh, info.color_0_scale);
    std::array<Attribute, 6> attributes = bakedAttributes(mesh, colors);
    std::string bin;
    const int index_view = addBakedBuffer(doc, mesh, bin, attributes);
    doc["meshes"] = {bakedPrimitives(doc, mesh, info.name, attributes, index_view)};
    doc["buffers"] = {{{"byteLength", bin.size()}, {"uri", percentEncodePath(info.bin_uri)}}};
    // The .gltf and its buffer, each through writeAtomically (placed with the command's other
    // outputs, the buffer first), every write checked.
    const std::string text = doc.dump(2) + "\n";
    const std::string bin_path = (fs::path(gltf_path).parent_path() / info.bin_uri).string();
    PENUMBRA_TRY(writeAtomically(
        bin_path, [&](const std::string& tmp) { return writeBytesTo(bin_path, tmp, bin); }));
    return writeAtomically(
        gltf_path, [&](const std::string& tmp) { return writeBytesTo(gltf_path, tmp, text); });
  } catch (const std::exception& e) {
    return runtimeError(gltf_path, std::string("cannot write glTF file: ") + e.what());
  }
}

}  // namespace penumbra
