#include "penumbra/io/gltf_writer.h"

#include "penumbra/io/asset_files.h"

#include "penumbra/core/check.h"
#include "penumbra/core/file_util.h"

#include <glm/common.hpp>

#include <tiny_gltf.h>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <exception>
#include <filesystem>
#include <limits>
#include <sstream>
#include <vector>

namespace penumbra {

namespace {

tinygltf::Value toValue(const nlohmann::json& j) {
  switch (j.type()) {
    case nlohmann::json::value_t::object: {
      tinygltf::Value::Object o;
      for (const auto& [key, value] : j.items()) o[key] = toValue(value);
      return tinygltf::Value(std::move(o));
    }
    case nlohmann::json::value_t::array: {
      tinygltf::Value::Array a;
      for (const nlohmann::json& value : j) a.push_back(toValue(value));
      return tinygltf::Value(std::move(a));
    }
    case nlohmann::json::value_t::string:
      return tinygltf::Value(j.get<std::string>());
    case nlohmann::json::value_t::boolean:
      return tinygltf::Value(j.get<bool>());
    case nlohmann::json::value_t::number_integer:
    case nlohmann::json::value_t::number_unsigned: {
      const double d = j.get<double>();
      if (d >= double(std::numeric_limits<int>::min()) &&
          d <= double(std::numeric_limits<int>::max())) {
        return tinygltf::Value(int(d));
      }
      return tinygltf::Value(d);
    }
    case nlohmann::json::value_t::number_float:
      return tinygltf::Value(j.get<double>());
    default:
      return tinygltf::Value();
  }
}

// Appends raw bytes to the buffer, 4-byte aligned, and returns their offset.
size_t append(std::vector<unsigned char>& data, const void* bytes, size_t size) {
  while (data.size() % 4 != 0) data.push_back(0);
  const size_t offset = data.size();
  data.resize(offset + size);
  if (size > 0) std::memcpy(data.data() + offset, bytes, size);
  return offset;
}

int addView(tinygltf::Model& model, size_t offset, size_t length, size_t stride, int target) {
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = offset;
  view.byteLength = length;
  view.byteStride = stride;
  view.target = target;
  model.bufferViews.push_back(view);
  return int(model.bufferViews.size()) - 1;
}

int addAccessor(tinygltf::Model& model, int view, size_t byte_offset, size_t count, int type,
                int component_type) {
  tinygltf::Accessor a;
  a.bufferView = view;
  a.byteOffset = byte_offset;
  a.count = count;
  a.type = type;
  a.componentType = component_type;
  model.accessors.push_back(a);
  return int(model.accessors.size()) - 1;
}

// The asset: its version, generator and extras.penumbra (the caller's extras and
// color_0_scale).
void describeAsset(tinygltf::Model& model, const BakedGltfInfo& info) {
  model.asset.version = "2.0";
  model.asset.generator = "penumbra 0.1.0";
  nlohmann::json extras = info.extras;
  extras["color_0_scale"] = info.color_0_scale;
  model.asset.extras = tinygltf::Value(tinygltf::Value::Object{{"penumbra", toValue(extras)}});
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
  int type;
  int view = -1;
};

// The attributes in buffer order; `colors` (bakedColors) must outlive them.
std::array<Attribute, 6> bakedAttributes(const BakedMesh& mesh,
                                         const std::vector<glm::vec3>& colors) {
  const std::vector<glm::vec2>& uv0 = mesh.has_scene_uvs ? mesh.uv0 : mesh.uv1;
  const size_t v3 = sizeof(glm::vec3), v2 = sizeof(glm::vec2);
  return {{
      {"POSITION", mesh.positions.data(), v3, TINYGLTF_TYPE_VEC3},
      {"NORMAL", mesh.normals.data(), v3, TINYGLTF_TYPE_VEC3},
      {"TEXCOORD_0", uv0.data(), v2, TINYGLTF_TYPE_VEC2},
      {"TEXCOORD_1", mesh.uv1.data(), v2, TINYGLTF_TYPE_VEC2},
      {"COLOR_0", colors.data(), v3, TINYGLTF_TYPE_VEC3},
      {"_RADIANCE", mesh.values.data(), v3, TINYGLTF_TYPE_VEC3},
  }};
}

// The buffer: attributes one after another (tightly packed), then the indices, local to each
// primitive's vertices. Sets each attribute's view; the indices' view.
int addBakedBuffer(tinygltf::Model& model, const BakedMesh& mesh, const std::string& bin_uri,
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
  tinygltf::Buffer buffer;
  buffer.uri = percentEncodePath(bin_uri);
  std::vector<unsigned char>& data = buffer.data;
  for (Attribute& a : attributes) {
    const size_t offset = append(data, a.data, a.stride * nv);
    a.view = addView(model, offset, a.stride * nv, a.stride, TINYGLTF_TARGET_ARRAY_BUFFER);
  }
  const size_t index_offset = append(data, indices.data(), indices.size() * sizeof(uint32_t));
  const int index_view = addView(model, index_offset, indices.size() * sizeof(uint32_t), 0,
                                 TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
  model.buffers.push_back(std::move(buffer));
  return index_view;
}

// The mesh: a primitive per group, with its accessors into the attributes' and indices' views.
tinygltf::Mesh bakedPrimitives(tinygltf::Model& model, const BakedMesh& mesh,
                               const std::string& name, const std::array<Attribute, 6>& attributes,
                               int index_view) {
  tinygltf::Mesh gltf_mesh;
  gltf_mesh.name = name;
  for (const BakedMesh::Group& g : mesh.groups) {
    tinygltf::Primitive p;
    p.mode = TINYGLTF_MODE_TRIANGLES;
    p.material = int(g.material);
    for (const Attribute& a : attributes) {
      const int accessor = addAccessor(model, a.view, size_t(g.first_vertex) * a.stride,
                                       g.vertex_count, a.type, TINYGLTF_COMPONENT_TYPE_FLOAT);
      p.attributes[a.name] = accessor;
    }
    // POSITION needs its bounds.
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    for (uint32_t v = g.first_vertex; v < g.first_vertex + g.vertex_count; ++v) {
      lo = glm::min(lo, mesh.positions[v]);
      hi = glm::max(hi, mesh.positions[v]);
    }
    tinygltf::Accessor& position = model.accessors[size_t(p.attributes["POSITION"])];
    position.minValues = {lo.x, lo.y, lo.z};
    position.maxValues = {hi.x, hi.y, hi.z};
    p.indices = addAccessor(model, index_view, size_t(g.first_triangle) * 3 * sizeof(uint32_t),
                            size_t(g.triangle_count) * 3, TINYGLTF_TYPE_SCALAR,
                            TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
    gltf_mesh.primitives.push_back(std::move(p));
  }
  return gltf_mesh;
}

// The lightmap: linear filtering without mipmaps (coarse mip levels would mix charts), clamped.
void addLightmap(tinygltf::Model& model, const std::string& lightmap_uri) {
  tinygltf::Image image;
  image.name = "lightmap";
  image.uri = percentEncodePath(lightmap_uri);
  image.mimeType = "image/png";
  model.images.push_back(image);
  tinygltf::Sampler sampler;
  sampler.magFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
  sampler.minFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
  sampler.wrapS = TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
  sampler.wrapT = TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
  model.samplers.push_back(sampler);
  tinygltf::Texture texture;
  texture.name = "lightmap";
  texture.source = 0;
  texture.sampler = 0;
  model.textures.push_back(texture);
}

// A scene material as glTF: black, emitting the lightmap (texture 0 on texCoord 1); its
// reflectance and emission in extras.penumbra.
tinygltf::Material bakedMaterial(const Material& m) {
  tinygltf::Material g;
  g.name = m.name;
  g.pbrMetallicRoughness.baseColorFactor = {0.0, 0.0, 0.0, 1.0};
  g.pbrMetallicRoughness.metallicFactor = 0.0;
  g.pbrMetallicRoughness.roughnessFactor = 1.0;
  g.emissiveFactor = {1.0, 1.0, 1.0};
  g.emissiveTexture.index = 0;
  g.emissiveTexture.texCoord = 1;
  g.extras = tinygltf::Value(tinygltf::Value::Object{
      {"penumbra", toValue({{"reflectance", {m.reflectance.x, m.reflectance.y, m.reflectance.z}},
                            {"emission", {m.emission.x, m.emission.y, m.emission.z}}})}});
  return g;
}

// One node holding mesh 0, in the default scene.
void addScene(tinygltf::Model& model, const std::string& name) {
  tinygltf::Node node;
  node.name = name;
  node.mesh = 0;
  model.nodes.push_back(node);
  tinygltf::Scene scene;
  scene.name = name;
  scene.nodes = {0};
  model.scenes.push_back(scene);
  model.defaultScene = 0;
}

// The .gltf and its buffer, each through writeAtomically (placed with the command's other
// outputs, the buffer first) and written with every call checked: tinygltf's own file writer does
// not check that its stream was flushed, so a full disk would leave a truncated .gltf. The model
// is serialised without the buffer's bytes (they move out of `model`), and the buffer entry then
// names the .bin.
Status writeGltfAndBuffer(tinygltf::Model& model, const std::string& gltf_path,
                          const std::string& bin_uri) {
  namespace fs = std::filesystem;
  const std::string bin_path = (fs::path(gltf_path).parent_path() / bin_uri).string();
  std::vector<unsigned char> bin;
  bin.swap(model.buffers.at(0).data);
  std::ostringstream json_text;
  tinygltf::TinyGLTF writer;
  writer.SetImageWriter(nullptr, nullptr);  // the PNG is written separately; keep its uri
  const bool serialised = writer.WriteGltfSceneToStream(&model, json_text, /*prettyPrint=*/true,
                                                        /*writeBinary=*/false);
  if (!serialised) return runtimeError(gltf_path, "cannot serialise the glTF document");
  nlohmann::json doc = nlohmann::json::parse(json_text.str());
  doc["buffers"][0] = {{"byteLength", bin.size()}, {"uri", percentEncodePath(bin_uri)}};
  const std::string text = doc.dump(2) + "\n";
  const std::string_view bin_bytes(reinterpret_cast<const char*>(bin.data()), bin.size());
  PENUMBRA_TRY(writeAtomically(
      bin_path, [&](const std::string& tmp) { return writeBytesTo(bin_path, tmp, bin_bytes); }));
  return writeAtomically(
      gltf_path, [&](const std::string& tmp) { return writeBytesTo(gltf_path, tmp, text); });
}

}  // namespace

Status writeBakedGltf(const std::string& gltf_path, const BakedMesh& mesh,
                      std::span<const Material> materials, const BakedGltfInfo& info) {
  const size_t nv = mesh.positions.size();
  PENUMBRA_CHECK(mesh.normals.size() == nv && mesh.values.size() == nv && mesh.uv0.size() == nv &&
                 mesh.uv1.size() == nv);
  try {
    tinygltf::Model model;
    describeAsset(model, info);
    const std::vector<glm::vec3> colors = bakedColors(mesh, info.color_0_scale);
    std::array<Attribute, 6> attributes = bakedAttributes(mesh, colors);
    const int index_view = addBakedBuffer(model, mesh, info.bin_uri, attributes);
    model.meshes.push_back(bakedPrimitives(model, mesh, info.name, attributes, index_view));
    addLightmap(model, info.lightmap_uri);
    for (const Material& m : materials) model.materials.push_back(bakedMaterial(m));
    addScene(model, info.name);
    PENUMBRA_TRY(writeGltfAndBuffer(model, gltf_path, info.bin_uri));
  } catch (const std::exception& e) {
    return runtimeError(gltf_path, std::string("cannot write glTF file: ") + e.what());
  }
  return {};
}

}  // namespace penumbra
