// glTF 2.0 loading (.gltf with external or data-URI buffers, .glb) through tinygltf.
//
// tinygltf parses the JSON and the buffers; everything read from a buffer is checked here
// (accessor type, bounds inside its buffer view and buffer, finite values, index ranges) since
// tinygltf does not check it, with errors naming the accessor. Conventions (docs/scene-format.md):
//   - units are metres; the default scene's node hierarchy is flattened into world space, normals
//     transformed by the inverse transpose; a node whose world transform mirrors (negative
//     determinant) has its triangles' winding flipped so front faces stay counter-clockwise;
//   - base colour factor (rgb) -> reflectance, times baseColorTexture and COLOR_0; emissive
//     factor x KHR_materials_emissive_strength -> emission, taken as radiance in W m^-2 sr^-1,
//     times emissiveTexture; alphaMode and alphaCutoff -> cut-outs (scene/material.h);
//   - textures through their sampler, texCoord and KHR_texture_transform; images in PNG, JPEG
//     and WebP (EXT_texture_webp), a missing or undecodable one an error naming the material;
//   - KHR_lights_punctual intensities are photometric (cd for point and spot, lx for directional)
//     and become radiometric by dividing by 683 lm/W and multiplying by the light's linear colour;
//   - lights and cameras look down their node's local -Z; a camera's up is the node's local +Y.
#include "penumbra/core/file_util.h"
#include "penumbra/core/memory.h"
#include "penumbra/io/gltf_common.h"
#include "penumbra/io/gltf_values.h"
#include "penumbra/io/image_io.h"
#include "penumbra/io/json_guard.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/io/subsurface_json.h"
#include "penumbra/io/texture_loader.h"
#include "penumbra/scene/media.h"

#include <tiny_gltf.h>
#include <nlohmann/json.hpp>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/matrix.hpp>

#include <fmt/format.h>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <numbers>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra {

namespace {

// The most triangles one glTF scene may instance (the engine indexes triangles with 32 bits;
// beyond this the memory guard refuses long before), and what each costs once loaded
// (positions, normals and indices of an expanded instance, with the vectors' slack).
constexpr uint64_t kMaxSceneTriangles = uint64_t(1) << 31;
constexpr uint64_t kLoadedBytesPerTriangle = 64;

// lm/W: luminous efficacy of monochromatic 555 nm light, the conversion KHR_lights_punctual
// implementations use between photometric and radiometric quantities.
constexpr double kLumensPerWatt = 683.0;

std::string oneLine(std::string s) {
  for (char& c : s) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

// A checked view of an accessor's elements.
struct AccessorView {
  const unsigned char* data = nullptr;  // first element
  size_t stride = 0;                    // bytes between elements
  size_t count = 0;
  int component_type = 0;
  int components = 0;
  bool normalized = false;

  // Component c of element i as a double (float, or a normalized / plain integer).
  double component(size_t i, int c) const {
    const unsigned char* p = data + i * stride;
    switch (component_type) {
      case TINYGLTF_COMPONENT_TYPE_FLOAT: {
        float f;
        std::memcpy(&f, p + 4 * c, 4);
        return f;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: {
        const double v = p[c];
        return normalized ? v / 255.0 : v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        uint16_t v;
        std::memcpy(&v, p + 2 * c, 2);
        return normalized ? v / 65535.0 : v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
        uint32_t v;
        std::memcpy(&v, p + 4 * c, 4);
        return v;
      }
      default:
        return 0.0;
    }
  }
  uint32_t index(size_t i) const {
    const unsigned char* p = data + i * stride;
    switch (component_type) {
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
        return p[0];
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        uint16_t v;
        std::memcpy(&v, p, 2);
        return v;
      }
      default: {
        uint32_t v;
        std::memcpy(&v, p, 4);
        return v;
      }
    }
  }
};

const char* typeName(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR:
      return "SCALAR";
    case TINYGLTF_TYPE_VEC2:
      return "VEC2";
    case TINYGLTF_TYPE_VEC3:
      return "VEC3";
    case TINYGLTF_TYPE_VEC4:
      return "VEC4";
    default:
      return "a matrix or unknown type";
  }
}

// What tinygltf takes on trust, checked on the JSON first: the asset's version (tinygltf reads
// glTF 1.0 files as if they were 2.0), the values it drops when their type is wrong
// (io/gltf_values.h) and that external buffers and images name files (a
// directory makes tinygltf fail with an allocation error).
Status checkGltfJson(const std::string& path, std::string_view text, const std::string& base) {
  const nlohmann::json root = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (root.is_discarded() || !root.is_object()) return {};  // tinygltf reports the syntax
  if (root.contains("asset") && root["asset"].is_object() && root["asset"].contains("version")) {
    const nlohmann::json& v = root["asset"]["version"];
    const std::string version = v.is_string() ? v.get<std::string>() : v.dump();
    if (version.rfind("2.", 0) != 0) {
      return inputError(path, "asset.version",
                        fmt::format("'{}': only glTF 2.0 is supported", version));
    }
  }
  PENUMBRA_TRY(checkGltfValues(path, root));
  for (const char* key : {"buffers", "images"}) {
    if (!root.contains(key) || !root[key].is_array()) continue;
    const nlohmann::json& list = root[key];
    for (size_t i = 0; i < list.size(); ++i) {
      if (!list[i].is_object() || !list[i].contains("uri") || !list[i]["uri"].is_string()) {
        continue;
      }
      const std::string uri = list[i]["uri"].get<std::string>();
      if (uri.rfind("data:", 0) == 0) continue;
      std::error_code ec;
      const std::filesystem::path file = std::filesystem::path(base) / uri;
      if (uri.empty() ||
          (std::filesystem::exists(file, ec) && !std::filesystem::is_regular_file(file, ec))) {
        return inputError(path, fmt::format("{}[{}]", key, i),
                          fmt::format("uri '{}' does not name a file", uri));
      }
    }
  }
  return {};
}

namespace {

// A tinygltf value as JSON (extension objects are parsed by the same code as the JSON scene's).
nlohmann::json toJson(const tinygltf::Value& v) {
  if (v.IsBool()) return v.Get<bool>();
  if (v.IsInt()) return v.GetNumberAsInt();
  if (v.IsNumber()) return v.GetNumberAsDouble();
  if (v.IsString()) return v.Get<std::string>();
  if (v.IsArray()) {
    nlohmann::json a = nlohmann::json::array();
    for (size_t i = 0; i < v.ArrayLen(); ++i) a.push_back(toJson(v.Get(int(i))));
    return a;
  }
  if (v.IsObject()) {
    nlohmann::json o = nlohmann::json::object();
    for (const std::string& k : v.Keys()) o[k] = toJson(v.Get(k));
    return o;
  }
  return nullptr;
}

}  // namespace

class GltfReader {
 public:
  GltfReader(const std::string& path, const tinygltf::Model& model,
             const std::map<int, std::string>& image_bytes, Scene& scene)
      : path_(path), model_(model), image_bytes_(image_bytes), scene_(scene) {}

  Status read();

 private:
  // `role` describes the use for messages ("mesh 0 primitive 1 POSITION"). `allowed` lists the
  // accepted component types; `type` the accessor type.
  Expected<AccessorView> view(int accessor_index, const std::string& role, int type,
                              std::initializer_list<int> allowed);
  // Adds node `node_index`'s mesh, camera and light with its parent's world transform `parent`
  // (the node's own is kept in world_ for its children).
  Status visitNode(int node_index, const glm::dmat4& parent);
  Status checkHierarchy();
  Status checkInstancedTriangles(const std::vector<int>& roots);
  Status addPrimitive(const tinygltf::Node& node, int mesh_index, size_t primitive_index,
                      const glm::dmat4& world_from_object);
  // A primitive's attributes into `mesh`: POSITION (`pos`, accessor `accessor`) and NORMAL in
  // world space, the TEXCOORD_n sets as they are; `where` names the primitive for messages.
  Status readPositions(const AccessorView& pos, int accessor, const std::string& where,
                       const glm::dmat4& world_from_object, Mesh& mesh);
  Status readNormals(const tinygltf::Primitive& prim, const std::string& where, size_t nv,
                     const glm::dmat4& world_from_object, Mesh& mesh);
  Status readUvs(const tinygltf::Primitive& prim, const std::string& where, size_t nv, Mesh& mesh);
  // The primitive's vertex sequence, from the index accessor or 0 .. nv-1.
  Expected<std::vector<uint32_t>> vertexSequence(const tinygltf::Primitive& prim,
                                                 const std::string& where, size_t nv);
  // The triangles of the sequence in draw mode `mode`, wound the other way when `mirrored`.
  void addTriangles(int mode, const std::vector<uint32_t>& seq, uint32_t material, bool mirrored,
                    const std::string& where, Mesh& mesh);
  Status addLight(int node_index, const glm::dmat4& world_from_light);
  Status addCamera(int node_index, int camera_index, const glm::dmat4& world_from_camera);
  Expected<uint32_t> materialFor(int gltf_material, const std::string& where);
  // A textureInfo as a binding: its image (EXT_texture_webp's first), sampler, texCoord and
  // KHR_texture_transform. `colour`: an sRGB colour texture; `place` names the material slot.
  Expected<TextureBinding> textureBinding(int texture_index, int tex_coord,
                                          const tinygltf::ExtensionMap& extensions, bool colour,
                                          const std::string& place);
  Status readColours(const tinygltf::Primitive& prim, const std::string& where, size_t nv,
                     Mesh& mesh);
  // PENUMBRA_materials_subsurface, else KHR_materials_volume with KHR_materials_transmission read
  // as a scattering medium (docs/scene-format.md).
  Status readSubsurface(const tinygltf::Material& gm, const std::string& place, Material& m);
  Expected<glm::dmat4> localTransform(int node_index);

  const std::string& path_;
  const tinygltf::Model& model_;
  const std::map<int, std::string>& image_bytes_;  // undecoded, by image index
  Scene& scene_;
  // KHR_materials_transmission (+ KHR_materials_ior) as glass, metallic 1 and roughness 0 as a
  // mirror (Material::scattering).
  Status readSpecular(const tinygltf::Material& gm, const std::string& place, Material& m);
  std::vector<int> material_map_;  // glTF material -> scene material, -1 until used
  TextureCache textures_;
  int default_material_ = -1;
  std::vector<int> parent_;        // per node, -1 for a root
  std::vector<glm::dmat4> world_;  // per node, once visited
};

Expected<AccessorView> GltfReader::view(int accessor_index, const std::string& role, int type,
                                        std::initializer_list<int> allowed) {
  if (accessor_index < 0 || static_cast<size_t>(accessor_index) >= model_.accessors.size()) {
    return inputError(path_, role,
                      fmt::format("accessor {} does not exist (the file has {})", accessor_index,
                                  model_.accessors.size()));
  }
  const tinygltf::Accessor& a = model_.accessors[static_cast<size_t>(accessor_index)];
  const std::string place = fmt::format("accessor {} ({})", accessor_index, role);
  if (a.sparse.isSparse) return inputError(path_, place, "sparse accessors are not supported");
  if (a.type != type) {
    return inputError(path_, place,
                      fmt::format("type is {}, expected {}", typeName(a.type), typeName(type)));
  }
  bool type_ok = false;
  for (int t : allowed) type_ok = type_ok || t == a.componentType;
  if (!type_ok) {
    return inputError(path_, place,
                      fmt::format("component type {} is not supported here", a.componentType));
  }
  if (a.bufferView < 0 || static_cast<size_t>(a.bufferView) >= model_.bufferViews.size()) {
    return inputError(path_, place,
                      a.bufferView < 0 ? std::string("has no bufferView (not supported)")
                                       : fmt::format("bufferView {} does not exist", a.bufferView));
  }
  const tinygltf::BufferView& bv = model_.bufferViews[static_cast<size_t>(a.bufferView)];
  if (bv.buffer < 0 || static_cast<size_t>(bv.buffer) >= model_.buffers.size()) {
    return inputError(path_, place,
                      fmt::format("bufferView {} refers to buffer {}, which does not exist",
                                  a.bufferView, bv.buffer));
  }
  const tinygltf::Buffer& buffer = model_.buffers[static_cast<size_t>(bv.buffer)];
  // Sizes come from the file: compare without overflowing.
  if (bv.byteOffset > buffer.data.size() || bv.byteLength > buffer.data.size() - bv.byteOffset) {
    return inputError(
        path_, place,
        fmt::format("bufferView {} (byteOffset {}, byteLength {}) lies outside "
                    "buffer {} ({} bytes)",
                    a.bufferView, bv.byteOffset, bv.byteLength, bv.buffer, buffer.data.size()));
  }
  const int components = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(a.type));
  const int component_size =
      tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(a.componentType));
  const size_t element_size = static_cast<size_t>(components) * component_size;
  const size_t stride = bv.byteStride == 0 ? element_size : bv.byteStride;
  if (stride < element_size) {
    return inputError(path_, place,
                      fmt::format("byteStride {} of bufferView {} is smaller than an element "
                                  "({} bytes)",
                                  bv.byteStride, a.bufferView, element_size));
  }
  if (a.count == 0) return inputError(path_, place, "count is 0");
  const size_t available = bv.byteLength;
  if (a.byteOffset > available || element_size > available - a.byteOffset ||
      (a.count - 1) > (available - a.byteOffset - element_size) / stride) {
    return inputError(
        path_, place,
        fmt::format("byteOffset {} + {} elements of {} bytes (stride {}) run past "
                    "the end of bufferView {} ({} bytes)",
                    a.byteOffset, a.count, element_size, stride, a.bufferView, bv.byteLength));
  }
  AccessorView v;
  v.data = buffer.data.data() + bv.byteOffset + a.byteOffset;
  v.stride = stride;
  v.count = a.count;
  v.component_type = a.componentType;
  v.components = components;
  v.normalized = a.normalized;
  return v;
}

Expected<uint32_t> GltfReader::materialFor(int gltf_material, const std::string& where) {
  if (gltf_material < 0) {
    if (default_material_ < 0) {
      default_material_ = static_cast<int>(scene_.materials.size());
      scene_.materials.push_back(Material{"default", glm::vec3(0.8f), glm::vec3(0.0f)});
    }
    return static_cast<uint32_t>(default_material_);
  }
  if (static_cast<size_t>(gltf_material) >= model_.materials.size()) {
    return inputError(path_, where, fmt::format("material {} does not exist", gltf_material));
  }
  int& mapped = material_map_[static_cast<size_t>(gltf_material)];
  if (mapped >= 0) return static_cast<uint32_t>(mapped);

  const tinygltf::Material& gm = model_.materials[static_cast<size_t>(gltf_material)];
  const std::string place = fmt::format("material {}", gltf_material);
  Material m;
  m.name = gm.name.empty() ? fmt::format("material{}", gltf_material) : gm.name;
  const std::vector<double>& base = gm.pbrMetallicRoughness.baseColorFactor;
  if (base.size() != 4) {
    return inputError(path_, place, "pbrMetallicRoughness.baseColorFactor needs 4 numbers");
  }
  m.reflectance = glm::vec3(base[0], base[1], base[2]);
  m.alpha = float(base[3]);
  m.two_sided = gm.doubleSided;
  const std::string label = fmt::format("{} ('{}')", place, m.name);
  if (gm.pbrMetallicRoughness.baseColorTexture.index >= 0) {
    const tinygltf::TextureInfo& info = gm.pbrMetallicRoughness.baseColorTexture;
    Expected<TextureBinding> b = textureBinding(info.index, info.texCoord, info.extensions, true,
                                                label + ".baseColorTexture");
    if (!b) return b.error();
    m.reflectance_texture = std::move(*b);
  }
  if (gm.alphaMode == "MASK") {
    m.alpha_mode = AlphaMode::kMask;
    m.alpha_cutoff = float(gm.alphaCutoff);
  } else if (gm.alphaMode == "BLEND") {
    m.alpha_mode = AlphaMode::kBlend;
  } else if (gm.alphaMode != "OPAQUE" && !gm.alphaMode.empty()) {
    return inputError(path_, label + ".alphaMode",
                      fmt::format("'{}' is not OPAQUE, MASK or BLEND", gm.alphaMode));
  }
  double strength = 1.0;
  auto ext = gm.extensions.find("KHR_materials_emissive_strength");
  if (ext != gm.extensions.end()) {
    if (!ext->second.IsObject() ||
        (ext->second.Has("emissiveStrength") && !ext->second.Get("emissiveStrength").IsNumber())) {
      return inputError(path_, place + ".extensions.KHR_materials_emissive_strength",
                        "emissiveStrength must be a number");
    }
    if (ext->second.Has("emissiveStrength")) {
      strength = ext->second.Get("emissiveStrength").GetNumberAsDouble();
    }
  }
  if (!gm.emissiveFactor.empty()) {
    if (gm.emissiveFactor.size() != 3) {
      return inputError(path_, place, "emissiveFactor needs 3 numbers");
    }
    m.emission = glm::vec3(
        glm::dvec3(gm.emissiveFactor[0], gm.emissiveFactor[1], gm.emissiveFactor[2]) * strength);
  }
  if (gm.emissiveTexture.index >= 0) {
    Expected<TextureBinding> b =
        textureBinding(gm.emissiveTexture.index, gm.emissiveTexture.texCoord,
                       gm.emissiveTexture.extensions, true, label + ".emissiveTexture");
    if (!b) return b.error();
    m.emission_texture = std::move(*b);
  }
  if (gm.normalTexture.index >= 0) {
    // Wallner sec. 3.3: a tangent-space normal map on TEXCOORD_0 (scene/material.h).
    const std::string texture_place = place + ".normalTexture";
    const int tex = gm.normalTexture.index;
    if (size_t(tex) >= model_.textures.size()) {
      return inputError(path_, texture_place, fmt::format("texture {} does not exist", tex));
    }
    const int source = model_.textures[size_t(tex)].source;
    const auto bytes = image_bytes_.find(source);
    if (gm.normalTexture.texCoord != 0) {
      scene_.warnings.push_back(fmt::format(
          "{}: {} ('{}'): normalTexture on TEXCOORD_{} is not used (only TEXCOORD_0 is read)",
          path_, place, m.name, gm.normalTexture.texCoord));
    } else if (bytes == image_bytes_.end()) {
      scene_.warnings.push_back(
          fmt::format("{}: {} ('{}'): normalTexture's image {} could not be read: not used", path_,
                      place, m.name, source));
    } else {
      Expected<Image> map = decodePngData(fmt::format("{} image {}", path_, source), bytes->second);
      if (!map) return map.error();
      m.normal_map = std::make_shared<const Image>(std::move(*map));
      m.normal_map_source = fmt::format("{} image {}", path_, source);
      m.normal_scale = float(gm.normalTexture.scale);
    }
  }
  PENUMBRA_TRY(readSubsurface(gm, place, m));
  if (!m.subsurface) PENUMBRA_TRY(readSpecular(gm, place, m));
  mapped = static_cast<int>(scene_.materials.size());
  scene_.materials.push_back(std::move(m));
  return static_cast<uint32_t>(mapped);
}

Expected<TextureBinding> GltfReader::textureBinding(int texture_index, int tex_coord,
                                                    const tinygltf::ExtensionMap& extensions,
                                                    bool colour, const std::string& place) {
  if (texture_index < 0 || size_t(texture_index) >= model_.textures.size()) {
    return inputError(path_, place, fmt::format("texture {} does not exist", texture_index));
  }
  const tinygltf::Texture& texture = model_.textures[size_t(texture_index)];
  TextureBinding binding;
  // The image: EXT_texture_webp's source when given (its fallback may be absent), else source.
  int source = texture.source;
  auto webp = texture.extensions.find("EXT_texture_webp");
  if (webp != texture.extensions.end() && webp->second.IsObject() && webp->second.Has("source") &&
      webp->second.Get("source").IsInt()) {
    source = webp->second.Get("source").GetNumberAsInt();
  }
  if (source < 0 || size_t(source) >= model_.images.size()) {
    return inputError(
        path_, place,
        fmt::format("texture {} has no image ({} does not exist)", texture_index, source));
  }
  const tinygltf::Image& image = model_.images[size_t(source)];
  const std::string name = image.uri.empty() || image.uri.rfind("data:", 0) == 0
                               ? fmt::format("{} image {}", path_, source)
                               : (std::filesystem::path(path_).parent_path() / image.uri).string();
  const auto bytes = image_bytes_.find(source);
  if (bytes == image_bytes_.end()) {
    return inputError(path_, place,
                      fmt::format("image '{}' (image {}) cannot be read: the file is missing or "
                                  "unreadable",
                                  name, source));
  }
  Expected<std::shared_ptr<const Texture>> t =
      textures_.bytes(name, bytes->second, colour, path_, place);
  if (!t) return t.error();
  binding.texture = *t;
  if (texture.sampler >= 0) {
    if (size_t(texture.sampler) >= model_.samplers.size()) {
      return inputError(path_, place, fmt::format("sampler {} does not exist", texture.sampler));
    }
    const tinygltf::Sampler& sampler = model_.samplers[size_t(texture.sampler)];
    auto wrap = [&](int mode, const char* axis) -> Expected<TextureWrap> {
      switch (mode) {
        case TINYGLTF_TEXTURE_WRAP_REPEAT:
          return TextureWrap::kRepeat;
        case TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE:
          return TextureWrap::kClampToEdge;
        case TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT:
          return TextureWrap::kMirroredRepeat;
        default:
          return inputError(path_, fmt::format("sampler {}.{}", texture.sampler, axis),
                            fmt::format("{} is not a glTF wrap mode", mode));
      }
    };
    Expected<TextureWrap> s = wrap(sampler.wrapS, "wrapS");
    if (!s) return s.error();
    Expected<TextureWrap> t_wrap = wrap(sampler.wrapT, "wrapT");
    if (!t_wrap) return t_wrap.error();
    binding.sampler.wrap_s = *s;
    binding.sampler.wrap_t = *t_wrap;
    binding.sampler.nearest = sampler.magFilter == TINYGLTF_TEXTURE_FILTER_NEAREST;
  }
  int uv_set = tex_coord;
  auto transform = extensions.find("KHR_texture_transform");
  if (transform != extensions.end() && transform->second.IsObject()) {
    const nlohmann::json x = toJson(transform->second);
    const std::string where = place + ".extensions.KHR_texture_transform";
    PENUMBRA_TRY(readTextureTransform(x, path_, where, binding));
    if (x.contains("texCoord")) {
      if (!x.at("texCoord").is_number_integer()) {
        return inputError(path_, where + ".texCoord", "must be an integer");
      }
      const int64_t set = x.at("texCoord").get<int64_t>();
      if (set < 0 || set > 7) {
        return inputError(path_, where + ".texCoord",
                          fmt::format("{} is not a UV set (0 to 7)", set));
      }
      uv_set = int(set);
    }
  }
  if (uv_set < 0 || uv_set > 7) {
    return inputError(path_, place, fmt::format("texCoord {} is not a UV set (0 to 7)", uv_set));
  }
  binding.uv_set = uint32_t(uv_set);
  return binding;
}

Status GltfReader::readSubsurface(const tinygltf::Material& gm, const std::string& place,
                                  Material& m) {
  auto own = gm.extensions.find("PENUMBRA_materials_subsurface");
  if (own != gm.extensions.end()) {
    Expected<Subsurface> s = parseSubsurface(toJson(own->second), path_,
                                             place + ".extensions.PENUMBRA_materials_subsurface");
    if (!s) return s.error();
    m.subsurface = *s;
  } else {
    auto volume = gm.extensions.find("KHR_materials_volume");
    if (volume == gm.extensions.end() ||
        gm.extensions.find("KHR_materials_transmission") == gm.extensions.end()) {
      return {};
    }
    // A transmissive volume read as a scattering medium: the base colour is the diffuse
    // reflectance it shows, attenuationDistance x attenuationColor how far light diffuses per
    // channel (a subsurface radius), KHR_materials_ior its index (glTF's default 1.5).
    const nlohmann::json v = toJson(volume->second);
    const std::string vplace = place + ".extensions.KHR_materials_volume";
    double distance = std::numeric_limits<double>::infinity();
    glm::dvec3 tint(1.0);
    if (v.contains("attenuationDistance")) {
      if (!v["attenuationDistance"].is_number() ||
          !(v["attenuationDistance"].get<double>() > 0.0)) {
        return inputError(path_, vplace + ".attenuationDistance", "must be a positive number");
      }
      distance = v["attenuationDistance"].get<double>();
    }
    if (v.contains("attenuationColor")) {
      const nlohmann::json& c = v["attenuationColor"];
      if (!c.is_array() || c.size() != 3) {
        return inputError(path_, vplace + ".attenuationColor", "needs 3 numbers");
      }
      for (int i = 0; i < 3; ++i) {
        if (!c[size_t(i)].is_number() || !(c[size_t(i)].get<double>() > 0.0)) {
          return inputError(path_, vplace + ".attenuationColor", "must be positive numbers");
        }
        tint[i] = c[size_t(i)].get<double>();
      }
    }
    // Without attenuationDistance the volume is clear: glass (readSpecular).
    if (!std::isfinite(distance)) return {};
    double eta = 1.5;
    auto ior = gm.extensions.find("KHR_materials_ior");
    if (ior != gm.extensions.end()) {
      const nlohmann::json i = toJson(ior->second);
      if (i.contains("ior")) {
        if (!i["ior"].is_number()) {
          return inputError(path_, place + ".extensions.KHR_materials_ior.ior", "must be a number");
        }
        eta = i["ior"].get<double>();
      }
    }
    const glm::dvec3 albedo = glm::min(glm::dvec3(m.reflectance), glm::dvec3(0.999));
    Expected<Subsurface> s = subsurfaceFromAlbedo(albedo, distance * tint, eta);
    if (!s) return inputError(path_, vplace, s.error().message);
    m.subsurface = *s;
    scene_.warnings.push_back(
        fmt::format("{}: {} ('{}'): KHR_materials_volume + KHR_materials_transmission read as a "
                    "scattering medium (base colour as its albedo, attenuation distance x colour "
                    "as its diffusion length)",
                    path_, place, m.name));
    return {};
  }
  // Methods without subsurface transport see the Lambertian surface that returns as much light.
  m.reflectance = glm::vec3(glm::clamp(lambertianAlbedo(*m.subsurface), 0.0, 1.0));
  return {};
}

Status GltfReader::readSpecular(const tinygltf::Material& gm, const std::string& place,
                                Material& m) {
  const glm::vec3 base = m.reflectance;
  auto transmission = gm.extensions.find("KHR_materials_transmission");
  if (transmission != gm.extensions.end()) {
    const nlohmann::json t = toJson(transmission->second);
    const std::string tplace = place + ".extensions.KHR_materials_transmission";
    double factor = 0.0;  // the extension's default
    if (t.contains("transmissionFactor")) {
      if (!t["transmissionFactor"].is_number() || !(t["transmissionFactor"].get<double>() >= 0.0 &&
                                                    t["transmissionFactor"].get<double>() <= 1.0)) {
        return inputError(path_, tplace + ".transmissionFactor", "must be a number in [0, 1]");
      }
      factor = t["transmissionFactor"].get<double>();
    }
    if (factor > 0.0) {
      // Smooth glass: the base colour filters the light it lets in, KHR_materials_ior gives its
      // index (the extension's default 1.5).
      double ior = 1.5;
      auto ext = gm.extensions.find("KHR_materials_ior");
      if (ext != gm.extensions.end()) {
        const nlohmann::json i = toJson(ext->second);
        if (i.contains("ior")) {
          if (!i["ior"].is_number() ||
              !(i["ior"].get<double>() >= 1.0 && i["ior"].get<double>() <= 4.0)) {
            return inputError(path_, place + ".extensions.KHR_materials_ior.ior",
                              "must be a number in [1, 4]");
          }
          ior = i["ior"].get<double>();
        }
      }
      m.scattering = Scattering::kDielectric;
      m.ior = float(ior);
      m.specular = glm::clamp(base, glm::vec3(0.0f), glm::vec3(1.0f));
      if (factor < 1.0) {
        scene_.warnings.push_back(
            fmt::format("{}: {} ('{}'): transmissionFactor {} read as 1 (smooth glass)", path_,
                        place, m.name, factor));
      }
      m.reflectance = diffuseStandIn(m);
      return {};
    }
  }
  // A smooth metal: a perfect mirror of the base colour.
  if (gm.pbrMetallicRoughness.metallicFactor == 1.0 &&
      gm.pbrMetallicRoughness.roughnessFactor == 0.0) {
    m.scattering = Scattering::kMirror;
    m.specular = glm::clamp(base, glm::vec3(0.0f), glm::vec3(1.0f));
    m.reflectance = diffuseStandIn(m);
  }
  return {};
}

Expected<glm::dmat4> GltfReader::localTransform(int node_index) {
  const tinygltf::Node& node = model_.nodes[static_cast<size_t>(node_index)];
  const std::string place = fmt::format("node {}", node_index);
  if (!node.matrix.empty()) {
    if (node.matrix.size() != 16) return inputError(path_, place, "matrix needs 16 numbers");
    glm::dmat4 m;
    for (int c = 0; c < 4; ++c) {
      for (int r = 0; r < 4; ++r) m[c][r] = node.matrix[static_cast<size_t>(4 * c + r)];
    }
    return m;  // glTF matrices are column-major, like glm
  }
  glm::dmat4 t(1.0), r(1.0), s(1.0);
  if (!node.translation.empty()) {
    if (node.translation.size() != 3)
      return inputError(path_, place, "translation needs 3 numbers");
    t[3] = glm::dvec4(node.translation[0], node.translation[1], node.translation[2], 1.0);
  }
  if (!node.rotation.empty()) {
    if (node.rotation.size() != 4) return inputError(path_, place, "rotation needs 4 numbers");
    // glTF stores x y z w; glm::dquat's constructor takes w first.
    const glm::dquat q(node.rotation[3], node.rotation[0], node.rotation[1], node.rotation[2]);
    if (!(glm::length(q) > 0.0)) return inputError(path_, place, "rotation is a zero quaternion");
    r = glm::mat4_cast(glm::normalize(q));
  }
  if (!node.scale.empty()) {
    if (node.scale.size() != 3) return inputError(path_, place, "scale needs 3 numbers");
    s[0][0] = node.scale[0];
    s[1][1] = node.scale[1];
    s[2][2] = node.scale[2];
  }
  return t * r * s;
}

Status GltfReader::visitNode(int node_index, const glm::dmat4& parent) {
  const size_t ni = static_cast<size_t>(node_index);
  Expected<glm::dmat4> local = localTransform(node_index);
  if (!local.ok()) return local.error();
  const glm::dmat4 world = parent * *local;
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 4; ++r) {
      if (!std::isfinite(world[c][r])) {
        return inputError(path_, fmt::format("node {}", node_index), "the transform is not finite");
      }
    }
  }
  world_[ni] = world;
  const tinygltf::Node& node = model_.nodes[ni];
  if (node.mesh >= 0) {
    if (node.skin >= 0) {
      scene_.warnings.push_back(
          fmt::format("{}: node {}: skinning is ignored; the mesh is used as posed by the node "
                      "transforms",
                      path_, node_index));
    }
    const tinygltf::Mesh& mesh = model_.meshes[static_cast<size_t>(node.mesh)];
    for (size_t p = 0; p < mesh.primitives.size(); ++p) {
      PENUMBRA_TRY(addPrimitive(node, node.mesh, p, world));
    }
  }
  if (node.camera >= 0) PENUMBRA_TRY(addCamera(node_index, node.camera, world));
  auto light = node.extensions.find("KHR_lights_punctual");
  if (light != node.extensions.end()) PENUMBRA_TRY(addLight(node_index, world));
  return {};
}

Status GltfReader::checkHierarchy() {
  // glTF 2.0 (sec. 3.5.3, "Nodes and Hierarchy"): the nodes form disjoint strict trees; no node
  // has two parents, and none is its own ancestor. A file that breaks this (a DAG, which
  // instances a subtree once per path and can grow exponentially, or a cycle) is refused.
  const size_t nn = model_.nodes.size();
  parent_.assign(nn, -1);
  for (size_t n = 0; n < nn; ++n) {
    for (int c : model_.nodes[n].children) {
      if (c < 0 || static_cast<size_t>(c) >= nn) {
        return inputError(path_, fmt::format("node {}", n),
                          fmt::format("child {} does not exist (the file has {} nodes)", c, nn));
      }
      const size_t ci = static_cast<size_t>(c);
      if (parent_[ci] >= 0) {
        return inputError(
            path_, fmt::format("node {}", n),
            parent_[ci] == static_cast<int>(n)
                ? fmt::format("child {} is listed twice (glTF nodes form trees)", c)
                : fmt::format("node {} is also a child of node {}: a node has at most one parent "
                              "(glTF nodes form trees)",
                              c, parent_[ci]));
      }
      parent_[ci] = static_cast<int>(n);
    }
    const tinygltf::Node& node = model_.nodes[n];
    if (node.mesh >= 0 && static_cast<size_t>(node.mesh) >= model_.meshes.size()) {
      return inputError(path_, fmt::format("node {}", n),
                        fmt::format("mesh {} does not exist", node.mesh));
    }
  }
  // A cycle: following parents from some node never ends at a root.
  std::vector<uint8_t> state(nn, 0);  // 0 unknown, 1 on the current walk, 2 reaches a root
  std::vector<size_t> walk;
  for (size_t n = 0; n < nn; ++n) {
    walk.clear();
    size_t at = n;
    while (state[at] == 0) {
      state[at] = 1;
      walk.push_back(at);
      if (parent_[at] < 0) break;
      at = static_cast<size_t>(parent_[at]);
    }
    if (state[at] == 1 && parent_[at] >= 0) {
      return inputError(path_, fmt::format("node {}", at), "the node hierarchy has a cycle");
    }
    for (size_t w : walk) state[w] = 2;
  }
  return {};
}

Status GltfReader::checkInstancedTriangles(const std::vector<int>& roots) {
  // Triangles the scene's trees instance (a mesh counts once per node that uses it), counted
  // before anything is built.
  std::vector<uint64_t> per_mesh(model_.meshes.size(), 0);
  for (size_t m = 0; m < model_.meshes.size(); ++m) {
    for (const tinygltf::Primitive& prim : model_.meshes[m].primitives) {
      const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
      int accessor = prim.indices;
      if (accessor < 0) {
        auto it = prim.attributes.find("POSITION");
        accessor = it == prim.attributes.end() ? -1 : it->second;
      }
      if (accessor < 0 || static_cast<size_t>(accessor) >= model_.accessors.size()) continue;
      const uint64_t count = model_.accessors[static_cast<size_t>(accessor)].count;
      if (mode == TINYGLTF_MODE_TRIANGLES) {
        per_mesh[m] += count / 3;
      } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP || mode == TINYGLTF_MODE_TRIANGLE_FAN) {
        per_mesh[m] += count >= 3 ? count - 2 : 0;
      }
    }
  }
  uint64_t total = 0;
  std::vector<int> stack(roots.rbegin(), roots.rend());
  while (!stack.empty()) {
    const tinygltf::Node& node = model_.nodes[static_cast<size_t>(stack.back())];
    stack.pop_back();
    if (node.mesh >= 0) total += per_mesh[static_cast<size_t>(node.mesh)];
    for (int c : node.children) stack.push_back(c);
  }
  if (total > kMaxSceneTriangles) {
    return inputError(path_, "nodes",
                      fmt::format("the scene instances {} triangles, more than the {} a scene may "
                                  "hold",
                                  total, kMaxSceneTriangles));
  }
  return checkMemory(total * kLoadedBytesPerTriangle,
                     fmt::format("{}: the scene's {} instanced triangles", path_, total));
}

Status GltfReader::addPrimitive(const tinygltf::Node& node, int mesh_index, size_t primitive_index,
                                const glm::dmat4& world_from_object) {
  const tinygltf::Mesh& gmesh = model_.meshes[static_cast<size_t>(mesh_index)];
  const tinygltf::Primitive& prim = gmesh.primitives[primitive_index];
  const std::string where = fmt::format("mesh {} primitive {}", mesh_index, primitive_index);
  const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
  if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
      mode != TINYGLTF_MODE_TRIANGLE_FAN) {
    scene_.warnings.push_back(
        fmt::format("{}: {}: points and lines (mode {}) are skipped", path_, where, mode));
    return {};
  }
  if (!prim.targets.empty()) {
    scene_.warnings.push_back(
        fmt::format("{}: {}: morph targets are ignored (the base shape is used)", path_, where));
  }
  auto pos_it = prim.attributes.find("POSITION");
  if (pos_it == prim.attributes.end()) {
    return inputError(path_, where, "the primitive has no POSITION attribute");
  }
  Expected<AccessorView> pos = view(pos_it->second, where + " POSITION", TINYGLTF_TYPE_VEC3,
                                    {TINYGLTF_COMPONENT_TYPE_FLOAT});
  if (!pos.ok()) return pos.error();
  const size_t nv = pos->count;

  Mesh mesh;
  mesh.name = !node.name.empty()    ? node.name
              : !gmesh.name.empty() ? gmesh.name
                                    : fmt::format("mesh{}", mesh_index);
  if (gmesh.primitives.size() > 1) mesh.name += fmt::format("#{}", primitive_index);
  PENUMBRA_TRY(readPositions(*pos, pos_it->second, where, world_from_object, mesh));
  PENUMBRA_TRY(readNormals(prim, where, nv, world_from_object, mesh));
  PENUMBRA_TRY(readUvs(prim, where, nv, mesh));
  PENUMBRA_TRY(readColours(prim, where, nv, mesh));
  Expected<std::vector<uint32_t>> seq = vertexSequence(prim, where, nv);
  if (!seq.ok()) return seq.error();

  Expected<uint32_t> material = materialFor(prim.material, where);
  if (!material.ok()) return material.error();
  const bool mirrored = glm::determinant(glm::dmat3(world_from_object)) < 0.0;
  addTriangles(mode, *seq, *material, mirrored, where, mesh);
  mesh.gltf_node = int(&node - model_.nodes.data());
  mesh.gltf_mesh = mesh_index;
  mesh.gltf_primitive = int(primitive_index);
  mesh.gltf_mirrored = mirrored;
  if (mesh.triangles.empty()) {
    scene_.warnings.push_back(fmt::format("{}: {}: no triangles", path_, where));
    return {};
  }
  scene_.meshes.push_back(std::move(mesh));
  return {};
}

Status GltfReader::readPositions(const AccessorView& pos, int accessor, const std::string& where,
                                 const glm::dmat4& world_from_object, Mesh& mesh) {
  const size_t nv = pos.count;
  mesh.positions.resize(nv);
  for (size_t i = 0; i < nv; ++i) {
    const glm::dvec3 p(pos.component(i, 0), pos.component(i, 1), pos.component(i, 2));
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      return inputError(path_,
                        fmt::format("accessor {} ({} POSITION), vertex {}", accessor, where, i),
                        "position is not a finite number");
    }
    mesh.positions[i] = glm::vec3(world_from_object * glm::dvec4(p, 1.0));
  }
  return {};
}

Status GltfReader::readNormals(const tinygltf::Primitive& prim, const std::string& where, size_t nv,
                               const glm::dmat4& world_from_object, Mesh& mesh) {
  auto nrm_it = prim.attributes.find("NORMAL");
  if (nrm_it == prim.attributes.end()) return {};
  Expected<AccessorView> nrm =
      view(nrm_it->second, where + " NORMAL", TINYGLTF_TYPE_VEC3, {TINYGLTF_COMPONENT_TYPE_FLOAT});
  if (!nrm.ok()) return nrm.error();
  if (nrm->count != nv) {
    return inputError(path_, fmt::format("accessor {} ({} NORMAL)", nrm_it->second, where),
                      fmt::format("count {} differs from POSITION's {}", nrm->count, nv));
  }
  const glm::dmat3 normal_from_object = glm::transpose(glm::inverse(glm::dmat3(world_from_object)));
  mesh.normals.resize(nv);
  for (size_t i = 0; i < nv; ++i) {
    const glm::dvec3 n(nrm->component(i, 0), nrm->component(i, 1), nrm->component(i, 2));
    if (!std::isfinite(n.x) || !std::isfinite(n.y) || !std::isfinite(n.z)) {
      return inputError(path_,
                        fmt::format("accessor {} ({} NORMAL), vertex {}", nrm_it->second, where, i),
                        "normal is not a finite number");
    }
    const glm::dvec3 w = normal_from_object * n;
    const double len = glm::length(w);
    mesh.normals[i] = len > 0.0 ? glm::vec3(w / len) : glm::vec3(0.0f);
  }
  return {};
}

Status GltfReader::readUvs(const tinygltf::Primitive& prim, const std::string& where, size_t nv,
                           Mesh& mesh) {
  // TEXCOORD_0 .. TEXCOORD_7: set n in mesh.uvSet(n); a set after a missing one stays empty.
  for (int set = 0; set < 8; ++set) {
    const std::string attribute = fmt::format("TEXCOORD_{}", set);
    auto uv_it = prim.attributes.find(attribute);
    if (uv_it == prim.attributes.end()) continue;
    Expected<AccessorView> uv =
        view(uv_it->second, where + " " + attribute, TINYGLTF_TYPE_VEC2,
             {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
              TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT});
    if (!uv.ok()) return uv.error();
    if (uv->count != nv) {
      return inputError(path_, fmt::format("accessor {} ({} {})", uv_it->second, where, attribute),
                        fmt::format("count {} differs from POSITION's {}", uv->count, nv));
    }
    if (set > 0 && mesh.extra_uvs.size() < size_t(set)) mesh.extra_uvs.resize(size_t(set));
    std::vector<glm::vec2>& uvs = set == 0 ? mesh.uvs : mesh.extra_uvs[size_t(set - 1)];
    uvs.resize(nv);
    mesh.uv_origin_top = true;  // glTF: (0, 0) is the top-left of an image
    for (size_t i = 0; i < nv; ++i) uvs[i] = glm::vec2(uv->component(i, 0), uv->component(i, 1));
  }
  return {};
}

Status GltfReader::readColours(const tinygltf::Primitive& prim, const std::string& where, size_t nv,
                               Mesh& mesh) {
  auto it = prim.attributes.find("COLOR_0");
  if (it == prim.attributes.end()) return {};
  if (it->second < 0 || size_t(it->second) >= model_.accessors.size()) {
    return inputError(path_, where + " COLOR_0",
                      fmt::format("accessor {} does not exist", it->second));
  }
  const int type = model_.accessors[size_t(it->second)].type == TINYGLTF_TYPE_VEC3
                       ? TINYGLTF_TYPE_VEC3
                       : TINYGLTF_TYPE_VEC4;
  Expected<AccessorView> c =
      view(it->second, where + " COLOR_0", type,
           {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
            TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT});
  if (!c.ok()) return c.error();
  const std::string place = fmt::format("accessor {} ({} COLOR_0)", it->second, where);
  if (c->count != nv) {
    return inputError(path_, place,
                      fmt::format("count {} differs from POSITION's {}", c->count, nv));
  }
  if (c->component_type != TINYGLTF_COMPONENT_TYPE_FLOAT && !c->normalized) {
    return inputError(path_, place, "integer colours must be normalized");
  }
  mesh.colors.resize(nv);
  for (size_t i = 0; i < nv; ++i) {
    glm::vec4 v(1.0f);
    for (int k = 0; k < c->components; ++k) v[k] = float(c->component(i, k));
    if (!(v.x >= 0.0f && v.x <= 1.0f && v.y >= 0.0f && v.y <= 1.0f && v.z >= 0.0f && v.z <= 1.0f &&
          v.w >= 0.0f && v.w <= 1.0f)) {
      return inputError(path_, fmt::format("{}, vertex {}", place, i), "colour is outside [0, 1]");
    }
    mesh.colors[i] = v;
  }
  return {};
}

Expected<std::vector<uint32_t>> GltfReader::vertexSequence(const tinygltf::Primitive& prim,
                                                           const std::string& where, size_t nv) {
  std::vector<uint32_t> seq;
  if (prim.indices >= 0) {
    Expected<AccessorView> idx =
        view(prim.indices, where + " indices", TINYGLTF_TYPE_SCALAR,
             {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
              TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT});
    if (!idx.ok()) return idx.error();
    seq.resize(idx->count);
    for (size_t i = 0; i < idx->count; ++i) {
      seq[i] = idx->index(i);
      if (seq[i] >= nv) {
        return inputError(
            path_, fmt::format("accessor {} ({} indices), element {}", prim.indices, where, i),
            fmt::format("vertex index {} is out of range ({} vertices)", seq[i], nv));
      }
    }
  } else {
    seq.resize(nv);
    for (size_t i = 0; i < nv; ++i) seq[i] = static_cast<uint32_t>(i);
  }
  return seq;
}

void GltfReader::addTriangles(int mode, const std::vector<uint32_t>& seq, uint32_t material,
                              bool mirrored, const std::string& where, Mesh& mesh) {
  if (mode == TINYGLTF_MODE_TRIANGLES && seq.size() % 3 != 0) {
    scene_.warnings.push_back(
        fmt::format("{}: {}: {} vertices is not a multiple of 3; the last {} are ignored", path_,
                    where, seq.size(), seq.size() % 3));
  }
  const std::vector<uint32_t> corners = gltfTriangleCorners(mode, seq);
  for (size_t i = 0; i + 2 < corners.size(); i += 3) {
    const uint32_t a = corners[i], b = corners[i + 1], c = corners[i + 2];
    mesh.triangles.push_back(mirrored ? glm::uvec3(a, c, b) : glm::uvec3(a, b, c));
    mesh.material_ids.push_back(material);
  }
}

Status GltfReader::addLight(int node_index, const glm::dmat4& world_from_light) {
  const tinygltf::Node& node = model_.nodes[static_cast<size_t>(node_index)];
  const tinygltf::Value& ext = node.extensions.at("KHR_lights_punctual");
  const std::string place = fmt::format("node {}.extensions.KHR_lights_punctual", node_index);
  if (!ext.IsObject() || !ext.Has("light") || !ext.Get("light").IsInt()) {
    return inputError(path_, place, "needs an integer 'light'");
  }
  const int li = ext.Get("light").GetNumberAsInt();
  if (li < 0 || static_cast<size_t>(li) >= model_.lights.size()) {
    return inputError(path_, place, fmt::format("light {} does not exist", li));
  }
  const tinygltf::Light& gl = model_.lights[static_cast<size_t>(li)];
  const std::string lplace = fmt::format("KHR_lights_punctual.lights[{}]", li);
  glm::dvec3 color(1.0);
  if (!gl.color.empty()) {
    if (gl.color.size() != 3) return inputError(path_, lplace, "color needs 3 numbers");
    color = glm::dvec3(gl.color[0], gl.color[1], gl.color[2]);
  }
  if (!(gl.intensity >= 0.0) || !std::isfinite(gl.intensity)) {
    return inputError(path_, lplace, "intensity must be a finite non-negative number");
  }
  const glm::vec3 radiometric(color * (gl.intensity / kLumensPerWatt));
  const glm::vec3 position(world_from_light * glm::dvec4(0.0, 0.0, 0.0, 1.0));
  const glm::dvec3 axis = glm::dmat3(world_from_light) * glm::dvec3(0.0, 0.0, -1.0);
  if (!(glm::length(axis) > 0.0)) {
    return inputError(path_, fmt::format("node {}", node_index),
                      "the light's transform is singular");
  }
  const glm::vec3 direction(glm::normalize(axis));
  if (gl.range > 0.0) {
    scene_.warnings.push_back(fmt::format(
        "{}: {}: range {} is ignored (lights fall off with the inverse square law only)", path_,
        lplace, gl.range));
  }
  if (gl.type == "point") {
    scene_.lights.push_back(PointLight{position, radiometric});
  } else if (gl.type == "spot") {
    const double inner = gl.spot.innerConeAngle, outer = gl.spot.outerConeAngle;
    if (!(inner >= 0.0 && inner < outer && outer <= 0.5 * std::numbers::pi + 1e-9)) {
      return inputError(path_, lplace,
                        fmt::format("spot cone angles need 0 <= innerConeAngle < outerConeAngle "
                                    "<= pi/2 (got {} and {})",
                                    inner, outer));
    }
    scene_.lights.push_back(SpotLight{position, direction, radiometric, static_cast<float>(inner),
                                      static_cast<float>(outer)});
  } else if (gl.type == "directional") {
    scene_.lights.push_back(DirectionalLight{direction, radiometric});
  } else {
    return inputError(path_, lplace, fmt::format("unknown light type '{}'", gl.type));
  }
  return {};
}

Status GltfReader::addCamera(int node_index, int camera_index,
                             const glm::dmat4& world_from_camera) {
  if (static_cast<size_t>(camera_index) >= model_.cameras.size()) {
    return inputError(path_, fmt::format("node {}", node_index),
                      fmt::format("camera {} does not exist", camera_index));
  }
  if (scene_.camera) return {};  // the first camera wins
  const tinygltf::Camera& gc = model_.cameras[static_cast<size_t>(camera_index)];
  if (gc.type != "perspective") {
    scene_.warnings.push_back(
        fmt::format("{}: camera {}: '{}' cameras are not supported, only perspective", path_,
                    camera_index, gc.type));
    return {};
  }
  const double yfov = gc.perspective.yfov;
  if (!(yfov > 0.0 && yfov < std::numbers::pi)) {
    return inputError(path_, fmt::format("camera {}", camera_index),
                      fmt::format("yfov {} must be in (0, pi)", yfov));
  }
  const glm::dmat3 linear(world_from_camera);
  const glm::dvec3 forward = linear * glm::dvec3(0.0, 0.0, -1.0);
  const glm::dvec3 up = linear * glm::dvec3(0.0, 1.0, 0.0);
  if (!(glm::length(forward) > 0.0) || !(glm::length(up) > 0.0)) {
    return inputError(path_, fmt::format("node {}", node_index),
                      "the camera's transform is singular");
  }
  Camera cam;
  const glm::dvec3 position(world_from_camera * glm::dvec4(0.0, 0.0, 0.0, 1.0));
  cam.position = glm::vec3(position);
  cam.look_at = glm::vec3(position + glm::normalize(forward));
  cam.up = glm::vec3(glm::normalize(up));
  cam.vertical_fov = static_cast<float>(yfov);
  scene_.camera = cam;
  return {};
}

const char* const kSupportedExtensions[] = {
    "KHR_lights_punctual",           "KHR_materials_emissive_strength",
    "PENUMBRA_materials_subsurface", "KHR_materials_volume",
    "KHR_materials_transmission",    "KHR_materials_ior",
    "KHR_texture_transform",         "EXT_texture_webp"};

Status GltfReader::read() {
  for (const std::string& ext : model_.extensionsRequired) {
    bool supported = false;
    for (const char* s : kSupportedExtensions) supported = supported || ext == s;
    if (!supported) {
      return inputError(path_, "extensionsRequired",
                        fmt::format("required extension '{}' is not supported", ext));
    }
  }
  material_map_.assign(model_.materials.size(), -1);
  PENUMBRA_TRY(checkHierarchy());
  world_.assign(model_.nodes.size(), glm::dmat4(1.0));

  std::vector<int> roots;
  if (!model_.scenes.empty()) {
    const int si = model_.defaultScene >= 0 ? model_.defaultScene : 0;
    if (static_cast<size_t>(si) >= model_.scenes.size()) {
      return inputError(path_, "scene", fmt::format("scene {} does not exist", si));
    }
    roots = model_.scenes[static_cast<size_t>(si)].nodes;
    std::vector<bool> listed(model_.nodes.size(), false);
    for (int r : roots) {
      const std::string place = fmt::format("scene {}", si);
      if (r < 0 || static_cast<size_t>(r) >= model_.nodes.size()) {
        return inputError(path_, place, fmt::format("node {} does not exist", r));
      }
      if (parent_[static_cast<size_t>(r)] >= 0) {
        return inputError(path_, place,
                          fmt::format("node {} is a child of node {}, not a root", r,
                                      parent_[static_cast<size_t>(r)]));
      }
      if (listed[static_cast<size_t>(r)]) {
        return inputError(path_, place, fmt::format("node {} is listed twice", r));
      }
      listed[static_cast<size_t>(r)] = true;
    }
  } else {
    // No scene: every node that is nobody's child is a root.
    std::vector<bool> is_child(model_.nodes.size(), false);
    for (const tinygltf::Node& n : model_.nodes) {
      for (int c : n.children) {
        if (c >= 0 && static_cast<size_t>(c) < is_child.size()) {
          is_child[static_cast<size_t>(c)] = true;
        }
      }
    }
    for (size_t i = 0; i < model_.nodes.size(); ++i) {
      if (!is_child[i]) roots.push_back(static_cast<int>(i));
    }
    if (!roots.empty()) {
      scene_.warnings.push_back(
          fmt::format("{}: the file defines no scene; all root nodes are loaded", path_));
    }
  }
  PENUMBRA_TRY(checkInstancedTriangles(roots));
  // Depth first, children in order (the order of the scene's meshes), with an explicit stack:
  // a chain of nodes thousands deep is a valid tree.
  std::vector<int> stack(roots.rbegin(), roots.rend());
  while (!stack.empty()) {
    const int n = stack.back();
    stack.pop_back();
    const int p = parent_[static_cast<size_t>(n)];
    PENUMBRA_TRY(visitNode(n, p < 0 ? glm::dmat4(1.0) : world_[static_cast<size_t>(p)]));
    const std::vector<int>& children = model_.nodes[static_cast<size_t>(n)].children;
    for (auto it = children.rbegin(); it != children.rend(); ++it) stack.push_back(*it);
  }
  return {};
}

}  // namespace

Expected<Scene> loadGltf(const std::string& path) {
  Expected<std::string> bytes = readFile(path);
  if (!bytes.ok()) return bytes.error();
  if (bytes->empty()) return inputError(path, "", "the file is empty");
  if (bytes->size() > 0xffffffffu) return inputError(path, "", "the file is larger than 4 GiB");

  Scene scene;
  scene.source = path;
  const std::string base_dir = std::filesystem::path(path).parent_path().string();
  const bool binary = bytes->size() >= 4 && bytes->compare(0, 4, "glTF") == 0;
  std::string_view json_text = *bytes;
  if (binary) {
    Expected<std::string_view> chunk = glbJsonChunk(path, *bytes);
    if (!chunk) return chunk.error();
    json_text = *chunk;
  }
  PENUMBRA_TRY(checkJsonNesting(path, json_text, /*comments=*/false));
  PENUMBRA_TRY(checkGltfJson(path, json_text, base_dir));

  tinygltf::Model model;
  std::map<int, std::string> image_bytes;
  std::string err, warn;
  bool ok = false;
  try {
    tinygltf::TinyGLTF loader;
    loader.SetImageLoader(&keepGltfImageBytes, &image_bytes);
    if (binary) {
      ok = loader.LoadBinaryFromMemory(&model, &err, &warn,
                                       reinterpret_cast<const unsigned char*>(bytes->data()),
                                       static_cast<unsigned int>(bytes->size()), base_dir);
    } else {
      ok = loader.LoadASCIIFromString(&model, &err, &warn, bytes->data(),
                                      static_cast<unsigned int>(bytes->size()), base_dir);
    }
  } catch (const std::exception& e) {
    return inputError(path, "", fmt::format("tinygltf failed: {}", e.what()));
  }
  if (!ok) {
    std::string message = oneLine(err.empty() ? "unknown error" : err);
    std::string place;
    // A JSON syntax error: nlohmann's message carries the line and column.
    const size_t at = message.find("parse error at line ");
    if (at != std::string::npos) {
      const size_t colon = message.find(": ", at);
      if (colon != std::string::npos) {
        place = message.substr(at + 15, colon - at - 15);
        message = "JSON " + message.substr(colon + 2);
      }
    }
    return inputError(path, place, fmt::format("not a valid glTF 2.0 file: {}", message));
  }
  if (!warn.empty()) scene.warnings.push_back(fmt::format("{}: tinygltf: {}", path, oneLine(warn)));

  GltfReader reader(path, model, image_bytes, scene);
  PENUMBRA_TRY(reader.read());
  PENUMBRA_TRY(validateScene(scene));
  return scene;
}

}  // namespace penumbra
