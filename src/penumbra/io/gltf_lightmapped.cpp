#include "penumbra/io/gltf_lightmapped.h"

#include "penumbra/core/check.h"
#include "penumbra/core/file_util.h"
#include "penumbra/io/asset_files.h"
#include "penumbra/io/gltf/gltf_accessor.h"
#include "penumbra/io/gltf_common.h"
#include "penumbra/io/image_decode.h"
#include "penumbra/io/image_io.h"

#include <glm/geometric.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <tuple>

namespace penumbra {

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

constexpr int kFloat = 5126, kUnsignedInt = 5125, kUnsignedShort = 5123;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;

// An accessor's elements as bytes in their buffer: element i at data + i * stride, `size` bytes.
struct AccessorBytes {
  const char* data = nullptr;  // null: no buffer view (every element zero)
  size_t stride = 0, size = 0, count = 0;
  int component_type = 0, components = 0;
};

// The document being changed, with the bytes of the one buffer it will have.
class Attacher {
 public:
  Attacher(GltfDocument& doc, std::string where) : doc_(doc), where_(std::move(where)) {}

  Expected<AccessorBytes> accessor(int index, const std::string& role) const {
    const json& accessors = doc_.json["accessors"];
    if (index < 0 || size_t(index) >= accessors.size()) {
      return inputError(where_, role, fmt::format("accessor {} does not exist", index));
    }
    const json& a = accessors[size_t(index)];
    const std::string place = fmt::format("accessor {} ({})", index, role);
    if (a.contains("sparse")) {
      return inputError(where_, place,
                        "sparse accessors are not carried into the lightmapped asset; bake with "
                        "--gltf emissive");
    }
    AccessorBytes r;
    r.count = a.value("count", size_t(0));
    r.component_type = a.value("componentType", 0);
    r.components = componentCount(a.value("type", std::string()));
    const int cs = componentSize(r.component_type);
    if (cs == 0 || r.components == 0) {
      return inputError(where_, place, "unknown componentType or type");
    }
    r.size = size_t(cs) * size_t(r.components);
    if (!a.contains("bufferView")) {
      r.stride = r.size;
      return r;
    }
    const int vi = a["bufferView"].get<int>();
    const json& views = doc_.json["bufferViews"];
    if (vi < 0 || size_t(vi) >= views.size()) {
      return inputError(where_, place, fmt::format("buffer view {} does not exist", vi));
    }
    const json& v = views[size_t(vi)];
    const size_t b = v.value("buffer", size_t(0));
    if (b >= doc_.buffers.size()) {
      return inputError(where_, place, fmt::format("buffer {} does not exist", b));
    }
    r.stride = v.value("byteStride", size_t(0));
    if (r.stride == 0) r.stride = r.size;
    const size_t begin = v.value("byteOffset", size_t(0)) + a.value("byteOffset", size_t(0));
    const size_t view_end = v.value("byteOffset", size_t(0)) + v.value("byteLength", size_t(0));
    const size_t need = r.count == 0 ? 0 : (r.count - 1) * r.stride + r.size;
    if (view_end > doc_.buffers[b].size() || begin > view_end || need > view_end - begin) {
      return inputError(where_, place, "its elements run past the end of its buffer view");
    }
    r.data = doc_.buffers[b].data() + begin;
    return r;
  }

  // The primitive's triangles as corner vertex indices, in file order (gltfTriangleCorners, as
  // the loader reads them).
  Expected<std::vector<uint32_t>> triangleCorners(const json& prim, const std::string& role) const {
    const int position = prim["attributes"].value("POSITION", -1);
    Expected<AccessorBytes> pos = accessor(position, role + " POSITION");
    if (!pos) return pos.error();
    std::vector<uint32_t> seq;
    if (prim.contains("indices")) {
      Expected<AccessorBytes> idx = accessor(prim["indices"].get<int>(), role + " indices");
      if (!idx) return idx.error();
      seq.resize(idx->count);
      for (size_t i = 0; i < idx->count; ++i) {
        const char* p = idx->data + i * idx->stride;
        if (idx->component_type == 5121) {
          seq[i] = uint8_t(*p);
        } else if (idx->component_type == kUnsignedShort) {
          uint16_t v;
          std::memcpy(&v, p, 2);
          seq[i] = v;
        } else {
          std::memcpy(&seq[i], p, 4);
        }
      }
    } else {
      seq.resize(pos->count);
      for (size_t i = 0; i < seq.size(); ++i) seq[i] = uint32_t(i);
    }
    const std::vector<uint32_t> corners = gltfTriangleCorners(prim.value("mode", 4), seq);
    for (uint32_t c : corners) {
      if (c >= pos->count) {
        return inputError(where_, role, fmt::format("vertex index {} is out of range", c));
      }
    }
    return corners;
  }

  // Appends bytes to the new buffer, 4-byte aligned, as a buffer view of its own.
  int addView(const std::string& bytes, size_t stride, int target) {
    while (bin_.size() % 4 != 0) bin_.push_back('\0');
    json v = {{"buffer", 0}, {"byteOffset", bin_.size()}, {"byteLength", bytes.size()}};
    if (stride > 0) v["byteStride"] = stride;
    if (target != 0) v["target"] = target;
    bin_ += bytes;
    doc_.json["bufferViews"].push_back(v);
    return int(doc_.json["bufferViews"].size()) - 1;
  }

  int addAccessor(json a) {
    doc_.json["accessors"].push_back(std::move(a));
    return int(doc_.json["accessors"].size()) - 1;
  }

  // Accessor `index` of `source`'s document gathered through `vertex` (new vertex k is old vertex
  // vertex[k]) into this one, with its type, normalisation and (recomputed) bounds.
  Expected<int> gatherFrom(const Attacher& source, int index, const std::vector<uint32_t>& vertex,
                           const std::string& role) {
    Expected<AccessorBytes> src = source.accessor(index, role);
    if (!src) return src.error();
    const json& a = source.doc_.json["accessors"][size_t(index)];
    const size_t stride = (src->size + 3) / 4 * 4;  // vertex attributes are 4-byte aligned
    std::string bytes(vertex.size() * stride, '\0');
    for (size_t k = 0; k < vertex.size(); ++k) {
      if (vertex[k] >= src->count) {
        return inputError(where_, role,
                          fmt::format("accessor {} has {} elements, vertex {} is used", index,
                                      src->count, vertex[k]));
      }
      if (src->data) {
        std::memcpy(&bytes[k * stride], src->data + vertex[k] * src->stride, src->size);
      }
    }
    json out = {{"bufferView", addView(bytes, stride == src->size ? 0 : stride, kArrayBuffer)},
                {"componentType", src->component_type},
                {"count", vertex.size()},
                {"type", a["type"]}};
    if (a.value("normalized", false)) out["normalized"] = true;
    if (a.contains("min") || a.contains("max")) {
      auto [lo, hi] = bounds(bytes, stride, *src, vertex.size());
      out["min"] = lo;
      out["max"] = hi;
    }
    return addAccessor(std::move(out));
  }

  std::string takeBin() { return std::move(bin_); }
  std::string& bin() { return bin_; }
  const std::string& where() const { return where_; }

 private:
  static std::pair<json, json> bounds(const std::string& bytes, size_t stride,
                                      const AccessorBytes& a, size_t count) {
    std::vector<double> lo(size_t(a.components), std::numeric_limits<double>::max()),
        hi(size_t(a.components), -std::numeric_limits<double>::max());
    const int cs = componentSize(a.component_type);
    for (size_t k = 0; k < count; ++k) {
      for (int c = 0; c < a.components; ++c) {
        const char* p = bytes.data() + k * stride + size_t(c * cs);
        double v = 0.0;
        switch (a.component_type) {
          case 5120:
            v = double(int8_t(*p));
            break;
          case 5121:
            v = double(uint8_t(*p));
            break;
          case 5122: {
            int16_t x;
            std::memcpy(&x, p, 2);
            v = x;
            break;
          }
          case 5123: {
            uint16_t x;
            std::memcpy(&x, p, 2);
            v = x;
            break;
          }
          case 5125: {
            uint32_t x;
            std::memcpy(&x, p, 4);
            v = x;
            break;
          }
          default: {
            float x;
            std::memcpy(&x, p, 4);
            v = x;
            break;
          }
        }
        lo[size_t(c)] = std::min(lo[size_t(c)], v);
        hi[size_t(c)] = std::max(hi[size_t(c)], v);
      }
    }
    if (count == 0) {
      std::fill(lo.begin(), lo.end(), 0.0);
      std::fill(hi.begin(), hi.end(), 0.0);
    }
    return {json(lo), json(hi)};
  }

  GltfDocument& doc_;
  std::string where_;
  std::string bin_;
};

// All buffers become buffer 0 (the originals one after another, 16-byte aligned), and images
// given by a file are appended as buffer views of it.
Status mergeBuffers(GltfDocument& doc, Attacher& at) {
  std::string& bin = at.bin();
  std::vector<size_t> base(doc.buffers.size());
  for (size_t b = 0; b < doc.buffers.size(); ++b) {
    while (bin.size() % 16 != 0) bin.push_back('\0');
    base[b] = bin.size();
    bin += doc.buffers[b];
    doc.buffers[b].clear();
  }
  if (doc.json.contains("bufferViews")) {
    for (json& v : doc.json["bufferViews"]) {
      const size_t b = v.value("buffer", size_t(0));
      v["buffer"] = 0;
      v["byteOffset"] = v.value("byteOffset", size_t(0)) + (b < base.size() ? base[b] : 0);
    }
  } else {
    doc.json["bufferViews"] = json::array();
  }
  for (auto& [index, bytes] : doc.file_images) {
    json& image = doc.json["images"][size_t(index)];
    // glTF takes PNG, JPEG and (EXT_texture_webp) WebP: a BMP or TGA texture (which Penumbra
    // reads) is written as a PNG of its texels, or the baked asset could not be opened again.
    const std::string name = image.value("uri", std::string());
    const ImageFormat format = imageFormatOf(name, bytes);
    std::string mime = format == ImageFormat::kJpeg   ? "image/jpeg"
                       : format == ImageFormat::kWebp ? "image/webp"
                                                      : "image/png";
    if (format == ImageFormat::kBmp || format == ImageFormat::kTga) {
      Expected<TextureTexels> texels = decodeTextureImage(name, bytes);
      if (!texels) return texels.error();
      Expected<std::string> png = encodePng8(texels->width, texels->height, texels->rgba8, 4);
      if (!png) return png.error();
      bytes = std::move(*png);
    }
    image.erase("uri");
    image["bufferView"] = at.addView(bytes, 0, 0);
    image["mimeType"] = mime;
    bytes.clear();
  }
  // Views made below read the originals through doc.buffers: point them at the merged bytes.
  doc.buffers.assign(1, std::string());
  return {};
}

// Adds the lightmap's image, sampler and texture; returns the texture's index.
int addLightmapTexture(json& j, const LightmapReference& lm) {
  for (const char* key : {"images", "samplers", "textures"}) {
    if (!j.contains(key)) j[key] = json::array();
  }
  j["images"].push_back({{"name", "penumbra_lightmap"},
                         {"uri", percentEncodePath(lm.png_uri)},
                         {"mimeType", "image/png"}});
  // Linear filtering without mipmaps (coarse levels would mix charts), clamped.
  j["samplers"].push_back(
      {{"magFilter", 9729}, {"minFilter", 9729}, {"wrapS", 33071}, {"wrapT", 33071}});
  j["textures"].push_back({{"name", "penumbra_lightmap"},
                           {"source", j["images"].size() - 1},
                           {"sampler", j["samplers"].size() - 1}});
  return int(j["textures"].size()) - 1;
}

}  // namespace

std::vector<GltfTriangleSource> gltfTriangleSources(const Scene& scene) {
  std::vector<GltfTriangleSource> out;
  for (const Mesh& m : scene.meshes) {
    if (m.gltf_node < 0) return {};
    for (uint32_t t = 0; t < m.triangles.size(); ++t) {
      out.push_back(
          {m.gltf_node, m.gltf_mesh, m.gltf_primitive, m.gltf_instance, t, m.gltf_mirrored});
    }
  }
  return out;
}

namespace {

// sRGB-encoded 8 bits of a linear value in [0, 1] (IEC 61966-2-1).
uint8_t srgbByte(float linear) {
  const float v = std::clamp(linear, 0.0f, 1.0f);
  const float e = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
  return uint8_t(std::lround(e * 255.0f));
}

// The textures of a scene that is not one glTF file, as glTF images, samplers and textures: each
// texture (as decoded, at the size it was kept) written as a PNG embedded in the buffer; an MTL
// cut-out (map_d, a mask of its own) becomes the alpha of the base colour's image, which is where
// glTF keeps coverage.
class SceneTextureWriter {
 public:
  SceneTextureWriter(GltfDocument& doc) : doc_(doc), j_(doc.json) {}

  // The glTF textureInfo of `colour` (null: white) with `alpha` (null: opaque) as its alpha,
  // read through `binding`'s UV set, transform and sampler; null when there is neither.
  Expected<json> textureInfo(const TextureBinding* colour, const TextureBinding* alpha,
                             bool uv_origin_top) {
    const TextureBinding* binding = colour ? colour : alpha;
    if (!binding) return json();
    Expected<int> image =
        imageOf(colour ? colour->texture.get() : nullptr, alpha ? alpha->texture.get() : nullptr);
    if (!image) return image.error();
    for (const char* key : {"images", "samplers", "textures"}) {
      if (!j_.contains(key)) j_[key] = json::array();
    }
    const auto wrap = [](TextureWrap w) {
      return w == TextureWrap::kClampToEdge      ? 33071
             : w == TextureWrap::kMirroredRepeat ? 33648
                                                 : 10497;
    };
    j_["samplers"].push_back({{"wrapS", wrap(binding->sampler.wrap_s)},
                              {"wrapT", wrap(binding->sampler.wrap_t)},
                              {"magFilter", binding->sampler.nearest ? 9728 : 9729}});
    j_["textures"].push_back({{"source", *image}, {"sampler", j_["samplers"].size() - 1}});
    json info = {{"index", j_["textures"].size() - 1}, {"texCoord", binding->uv_set}};
    addTransform(*binding, uv_origin_top, info);
    return info;
  }

 private:
  // KHR_texture_transform of the binding's rows, for UVs written with v down (the mesh's own are
  // flipped when they run up): (s, t) = M (u, v, 1), M = T(offset) R(rotation) S(scale).
  void addTransform(const TextureBinding& b, bool uv_origin_top, json& info) {
    glm::vec3 ru = b.row_u, rv = b.row_v;
    if (!uv_origin_top) {  // v_file = 1 - v_written, and t = 1 - v'
      ru = glm::vec3(ru.x, -ru.y, ru.y + ru.z);
      rv = glm::vec3(-rv.x, rv.y, 1.0f - rv.y - rv.z);
    }
    if (ru == glm::vec3(1.0f, 0.0f, 0.0f) && rv == glm::vec3(0.0f, 1.0f, 0.0f)) return;
    const float sx = std::hypot(ru.x, rv.x);
    const float rotation = std::atan2(-rv.x, ru.x);
    const float det = ru.x * rv.y - ru.y * rv.x;
    const float sy = std::copysign(std::hypot(ru.y, rv.y), det);
    info["extensions"]["KHR_texture_transform"] = {
        {"offset", {ru.z, rv.z}}, {"rotation", rotation}, {"scale", {sx, sy}}};
    used_transform_ = true;
  }

  Expected<int> imageOf(const Texture* colour, const Texture* alpha) {
    const auto key = std::make_pair(colour, alpha);
    auto it = images_.find(key);
    if (it != images_.end()) return it->second;
    const Texture& size = colour ? *colour : *alpha;
    const int w = size.width(), h = size.height();
    std::vector<uint8_t> rgba(size_t(w) * size_t(h) * 4);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        glm::vec4 c = colour ? colour->fetch(0, x, y) : glm::vec4(1.0f);
        if (alpha) {
          // The mask at the same place of its own image (map_d: its alpha, else its first channel).
          const int ax = x * alpha->width() / w, ay = y * alpha->height() / h;
          const glm::vec4 a = alpha->fetch(0, ax, ay);
          c.w = alpha->fileChannels() == 2 || alpha->fileChannels() == 4 ? a.w : a.x;
        }
        uint8_t* p = &rgba[(size_t(y) * size_t(w) + size_t(x)) * 4];
        for (int k = 0; k < 3; ++k) p[k] = srgbByte(c[k]);
        p[3] = uint8_t(std::lround(std::clamp(c.w, 0.0f, 1.0f) * 255.0f));
      }
    }
    Expected<std::string> png = encodePng8(w, h, rgba, 4);
    if (!png) return png.error();
    if (!j_.contains("images")) j_["images"] = json::array();
    j_["images"].push_back({{"name", fs::path(size.source()).filename().string()}});
    const int index = int(j_["images"].size()) - 1;
    doc_.file_images.emplace_back(index, std::move(*png));
    images_[key] = index;
    return index;
  }

 public:
  bool usedTransform() const { return used_transform_; }

 private:
  GltfDocument& doc_;
  json& j_;
  std::map<std::pair<const Texture*, const Texture*>, int> images_;
  bool used_transform_ = false;
};

// The steps of documentFromScene, over the document and the bytes of its one buffer.
class SceneDocumentWriter {
 public:
  SceneDocumentWriter(const Scene& scene, GltfDocument& doc)
      : scene_(scene), doc_(doc), j_(doc.json), textures_(doc) {
    j_ = {{"asset", {{"version", "2.0"}}},
          {"scene", 0},
          {"scenes", json::array({{{"nodes", json::array()}}})},
          {"nodes", json::array()},
          {"meshes", json::array()},
          {"materials", json::array()},
          {"accessors", json::array()},
          {"bufferViews", json::array()},
          {"buffers", json::array({json::object()})}};
    // Whether the scene's UVs run up (OBJ, JSON) or down (glTF): the transforms follow.
    for (const Mesh& m : scene.meshes) uv_origin_top_ = uv_origin_top_ || m.uv_origin_top;
  }

  // glTF materials (metallic 0, roughness 1) with their textures and cut-outs (images re-encoded
  // from what was decoded); emission over 1 as KHR_materials_emissive_strength.
  void materials() {
    bool emissive_strength = false;
    for (const Material& m : scene_.materials) {
      json g = {{"name", m.name},
                {"pbrMetallicRoughness",
                 {{"baseColorFactor", {m.reflectance.x, m.reflectance.y, m.reflectance.z, 1.0}},
                  {"metallicFactor", 0.0},
                  {"roughnessFactor", 1.0}}},
                {"doubleSided", m.two_sided}};
      const float peak = std::max({m.emission.x, m.emission.y, m.emission.z});
      if (peak > 0.0f) {
        const float s = std::max(peak, 1.0f);
        g["emissiveFactor"] = {m.emission.x / s, m.emission.y / s, m.emission.z / s};
        if (s > 1.0f) {
          g["extensions"]["KHR_materials_emissive_strength"] = {{"emissiveStrength", s}};
          emissive_strength = true;
        }
      }
      const TextureBinding* colour = m.reflectance_texture ? &*m.reflectance_texture : nullptr;
      const TextureBinding* mask = m.coverage_texture ? &*m.coverage_texture : nullptr;
      if (Expected<json> base = textures_.textureInfo(colour, mask, uv_origin_top_);
          base && !base->is_null()) {
        g["pbrMetallicRoughness"]["baseColorTexture"] = *base;
        if (!colour) g["pbrMetallicRoughness"]["baseColorFactor"] = {1.0, 1.0, 1.0, 1.0};
      }
      if (m.emission_texture) {
        Expected<json> e = textures_.textureInfo(&*m.emission_texture, nullptr, uv_origin_top_);
        if (e && !e->is_null()) g["emissiveTexture"] = *e;
      }
      g["pbrMetallicRoughness"]["baseColorFactor"][3] = m.alpha;
      if (m.alpha_mode == AlphaMode::kMask) {
        g["alphaMode"] = "MASK";
        g["alphaCutoff"] = m.alpha_cutoff;
      } else if (m.alpha_mode == AlphaMode::kBlend) {
        g["alphaMode"] = "BLEND";
      }
      j_["materials"].push_back(g);
    }
    if (emissive_strength) j_["extensionsUsed"] = {"KHR_materials_emissive_strength"};
    if (textures_.usedTransform()) {
      if (!j_.contains("extensionsUsed")) j_["extensionsUsed"] = json::array();
      j_["extensionsUsed"].push_back("KHR_texture_transform");
    }
  }

  // Mesh `mi` as a glTF mesh (a primitive per material, its triangles in the mesh's order) under
  // a node of its own; `sources` gains where each of its triangles went.
  void mesh(size_t mi, std::vector<GltfTriangleSource>& sources) {
    const Mesh& m = scene_.meshes[mi];
    const json attributes = vertexAttributes(m);
    std::map<uint32_t, std::vector<uint32_t>> by_material;
    for (uint32_t t = 0; t < m.triangles.size(); ++t) by_material[m.material_ids[t]].push_back(t);
    std::vector<std::pair<uint32_t, uint32_t>> place(m.triangles.size());  // (primitive, index)
    json prims = json::array();
    for (const auto& [material, tris] : by_material) {
      std::vector<uint32_t> idx;
      for (uint32_t k = 0; k < tris.size(); ++k) {
        place[tris[k]] = {uint32_t(prims.size()), k};
        idx.insert(idx.end(),
                   {m.triangles[tris[k]].x, m.triangles[tris[k]].y, m.triangles[tris[k]].z});
      }
      const size_t ia = accessor(view(idx.data(), idx.size() * 4, 0, kElementArrayBuffer),
                                 idx.size(), "SCALAR", kUnsignedInt);
      prims.push_back({{"attributes", attributes}, {"indices", ia}, {"material", material}});
    }
    for (uint32_t t = 0; t < m.triangles.size(); ++t) {
      sources.push_back(
          {int32_t(mi), int32_t(mi), int32_t(place[t].first), -1, place[t].second, false});
    }
    j_["meshes"].push_back({{"name", m.name}, {"primitives", prims}});
    j_["nodes"].push_back({{"name", m.name}, {"mesh", mi}});
    j_["scenes"][0]["nodes"].push_back(mi);
  }

  // The scene's camera as a node; glTF cameras look down their local -Z with +Y up (sec. 3.10.1).
  void camera() {
    if (!scene_.camera) return;
    const Camera& c = *scene_.camera;
    const glm::vec3 forward = glm::normalize(c.look_at - c.position);
    const glm::vec3 right = glm::normalize(glm::cross(forward, c.up));
    const glm::vec3 up = glm::cross(right, forward);
    j_["cameras"] = json::array(
        {{{"type", "perspective"}, {"perspective", {{"yfov", c.vertical_fov}, {"znear", 0.01}}}}});
    j_["nodes"].push_back(
        {{"name", "camera"},
         {"camera", 0},
         {"matrix",
          {right.x, right.y, right.z, 0.0, up.x, up.y, up.z, 0.0, -forward.x, -forward.y,
           -forward.z, 0.0, c.position.x, c.position.y, c.position.z, 1.0}}});
    j_["scenes"][0]["nodes"].push_back(j_["nodes"].size() - 1);
  }

  void finish() { doc_.buffers.push_back(std::move(bin_)); }

 private:
  size_t view(const void* data, size_t size, size_t stride, int target) {
    while (bin_.size() % 4 != 0) bin_.push_back('\0');
    json v = {{"buffer", 0}, {"byteOffset", bin_.size()}, {"byteLength", size}, {"target", target}};
    if (stride) v["byteStride"] = stride;
    bin_.append(static_cast<const char*>(data), size);
    j_["bufferViews"].push_back(v);
    return j_["bufferViews"].size() - 1;
  }

  size_t accessor(size_t v, size_t count, const char* type, int component) {
    j_["accessors"].push_back(
        {{"bufferView", v}, {"componentType", component}, {"count", count}, {"type", type}});
    return j_["accessors"].size() - 1;
  }

  // The mesh's positions (with their bounds, as glTF requires), normals, UV sets and colours.
  json vertexAttributes(const Mesh& m) {
    const size_t nv = m.positions.size();
    json attributes;
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    for (const glm::vec3& p : m.positions) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
    const size_t pa =
        accessor(view(m.positions.data(), nv * 12, 12, kArrayBuffer), nv, "VEC3", kFloat);
    j_["accessors"][pa]["min"] = {lo.x, lo.y, lo.z};
    j_["accessors"][pa]["max"] = {hi.x, hi.y, hi.z};
    attributes["POSITION"] = pa;
    if (m.normals.size() == nv) {
      attributes["NORMAL"] =
          accessor(view(m.normals.data(), nv * 12, 12, kArrayBuffer), nv, "VEC3", kFloat);
    }
    for (uint32_t set = 0; set < 8; ++set) {
      if (m.uvSet(set).size() != nv) continue;
      std::vector<glm::vec2> uv = m.uvSet(set);
      if (!m.uv_origin_top) {
        for (glm::vec2& t : uv) t.y = 1.0f - t.y;  // glTF: (0, 0) is the image's top-left
      }
      attributes[fmt::format("TEXCOORD_{}", set)] =
          accessor(view(uv.data(), nv * 8, 8, kArrayBuffer), nv, "VEC2", kFloat);
    }
    if (m.colors.size() == nv) {
      attributes["COLOR_0"] =
          accessor(view(m.colors.data(), nv * 16, 16, kArrayBuffer), nv, "VEC4", kFloat);
    }
    return attributes;
  }

  const Scene& scene_;
  GltfDocument& doc_;
  json& j_;
  SceneTextureWriter textures_;
  std::string bin_;
  bool uv_origin_top_ = false;
};

}  // namespace

GltfDocument documentFromScene(const Scene& scene, std::vector<GltfTriangleSource>& sources) {
  GltfDocument doc;
  SceneDocumentWriter writer(scene, doc);
  writer.materials();
  sources.clear();
  for (size_t mi = 0; mi < scene.meshes.size(); ++mi) writer.mesh(mi, sources);
  writer.camera();
  writer.finish();
  return doc;
}

namespace {

using InstanceKey = std::tuple<int, int, int>;  // node, mesh, primitive

// The steps of writeLightmappedGltf, over the document and its merged buffer.
class LightmapWriter {
 public:
  LightmapWriter(GltfDocument& doc, const std::string& gltf_path)
      : doc_(doc), j_(doc.json), at_(doc, doc.path.empty() ? gltf_path : doc.path) {}

  // The corners' lightmap UVs per primitive instance, in the file's corner order, and the
  // primitives' triangles as the file has them (read before the buffers merge).
  Status collect(std::span<const GltfTriangleSource> sources,
                 std::span<const TriangleLightmapUvs> uvs) {
    for (size_t t = 0; t < sources.size(); ++t) {
      const GltfTriangleSource& s = sources[t];
      // A copy of an EXT_mesh_gpu_instancing node is a node of its own in the plain document.
      int node = s.node;
      if (s.instance >= 0) {
        auto copy = doc_.instance_nodes.find({s.node, s.instance});
        if (copy == doc_.instance_nodes.end()) {
          return inputError(at_.where(), fmt::format("node {}", s.node),
                            "the file has changed since it was loaded");
        }
        node = copy->second;
      }
      std::vector<glm::vec2>& c = instances_[{node, s.mesh, s.primitive}];
      const size_t end = 3 * (size_t(s.triangle) + 1);
      if (c.size() < end) c.resize(end, glm::vec2(0.0f));
      c[end - 3] = uvs[t].uv[0];
      c[end - 2] = s.mirrored ? uvs[t].uv[2] : uvs[t].uv[1];
      c[end - 1] = s.mirrored ? uvs[t].uv[1] : uvs[t].uv[2];
    }
    for (const auto& [key, c] : instances_) {
      const auto [node, mesh, prim] = key;
      const std::string role = fmt::format("mesh {} primitive {}", mesh, prim);
      Expected<std::vector<uint32_t>> tc =
          at_.triangleCorners(j_["meshes"][size_t(mesh)]["primitives"][size_t(prim)], role);
      if (!tc) return tc.error();
      if (tc->size() < c.size()) {
        return inputError(at_.where(), role, "the file has changed since it was loaded");
      }
      corners_[key] = std::move(*tc);
    }
    return {};
  }

  // Gathering reads the original buffers: a copy of them is kept, then all become buffer 0.
  Status mergeBuffers() {
    originals_.json = j_;
    originals_.buffers = doc_.buffers;
    reader_ = std::make_unique<Attacher>(originals_, at_.where());
    return penumbra::mergeBuffers(doc_, at_);
  }

  Status attachAll() {
    for (const auto& [key, c] : instances_) {
      const auto [node, source_mesh, prim_index] = key;
      const int mesh = meshFor(node, source_mesh);
      json& prim = j_["meshes"][size_t(mesh)]["primitives"][size_t(prim_index)];
      const std::string role = fmt::format("mesh {} primitive {}", source_mesh, prim_index);
      Expected<int> set = attach(prim, corners_[key], c, role);
      if (!set) return set.error();
      prim["material"] = materialFor(prim.value("material", -1), *set);
    }
    return {};
  }

  // The extension on every lightmapped material, the asset's extras, the one buffer.
  std::string finish(const LightmapReference& lm, const json& penumbra_extras,
                     const std::string& bin_uri) {
    const int texture = addLightmapTexture(j_, lm);
    for (const auto& [material, set] : material_set_) {
      j_["materials"][size_t(material)]["extensions"]["PENUMBRA_lightmap"] = {
          {"index", texture},
          {"texCoord", set},
          {"encoding", "RGBM"},
          {"scale", lm.scale},
          {"quantity", "irradiance"},
          {"units", "W m^-2"},
          {"exr", percentEncodePath(lm.exr_uri)}};
    }
    if (!j_.contains("extensionsUsed")) j_["extensionsUsed"] = json::array();
    j_["extensionsUsed"].push_back("PENUMBRA_lightmap");
    json& asset = j_["asset"];
    const std::string generator = asset.value("generator", std::string());
    asset["generator"] = "penumbra 0.1.0";
    json extras = penumbra_extras;
    if (!generator.empty()) extras["source_generator"] = generator;
    if (!asset.contains("extras") || !asset["extras"].is_object()) asset["extras"] = json::object();
    asset["extras"]["penumbra"] = extras;
    std::string bin = at_.takeBin();
    j_["buffers"] =
        json::array({{{"byteLength", bin.size()}, {"uri", percentEncodePath(bin_uri)}}});
    return bin;
  }

 private:
  // The mesh node `node` lightmaps: its own, or a copy when another node already lightmaps it
  // (each instance has its own place in the lightmap).
  int meshFor(int node, int source_mesh) {
    auto owner = mesh_owner_.find(source_mesh);
    if (owner == mesh_owner_.end() || owner->second == node) {
      mesh_owner_[source_mesh] = node;
      return source_mesh;
    }
    auto copy = copies_.find({node, source_mesh});
    if (copy == copies_.end()) {
      j_["meshes"].push_back(originals_.json["meshes"][size_t(source_mesh)]);
      copy = copies_.emplace(std::make_pair(node, source_mesh), int(j_["meshes"].size()) - 1).first;
      j_["nodes"][size_t(node)]["mesh"] = copy->second;
    }
    return copy->second;
  }

  // Adds the lightmap UVs to the primitive (splitting vertices where they differ); returns the
  // UV set they are on.
  Expected<int> attach(json& prim, const std::vector<uint32_t>& tc, const std::vector<glm::vec2>& c,
                       const std::string& role) {
    // New vertices: one per (original vertex, lightmap UV) pair.
    std::vector<std::tuple<uint32_t, float, float, uint32_t>> pairs(tc.size());
    for (size_t k = 0; k < tc.size(); ++k) {
      const glm::vec2 uv = k < c.size() ? c[k] : glm::vec2(0.0f);
      pairs[k] = {tc[k], uv.x, uv.y, uint32_t(k)};
    }
    std::sort(pairs.begin(), pairs.end());
    std::vector<uint32_t> vertex, index(tc.size());
    std::vector<glm::vec2> vertex_uv;
    for (size_t k = 0; k < pairs.size(); ++k) {
      const auto& [v, u, w, corner] = pairs[k];
      if (k == 0 || std::get<0>(pairs[k - 1]) != v || std::get<1>(pairs[k - 1]) != u ||
          std::get<2>(pairs[k - 1]) != w) {
        vertex.push_back(v);
        vertex_uv.emplace_back(u, w);
      }
      index[corner] = uint32_t(vertex.size() - 1);
    }
    json& attributes = prim["attributes"];
    Expected<AccessorBytes> pos =
        reader_->accessor(attributes.value("POSITION", -1), role + " POSITION");
    if (!pos) return pos.error();
    std::vector<int32_t> uv_of(pos->count, -1);
    bool split = false;
    for (size_t k = 0; k < vertex.size(); ++k) {
      if (uv_of[vertex[k]] >= 0) split = true;
      uv_of[vertex[k]] = int32_t(k);
    }
    std::vector<glm::vec2> lightmap_uv;
    if (!split) {
      // Every used vertex has one UV: the primitive keeps its accessors and indices.
      lightmap_uv.assign(pos->count, glm::vec2(0.0f));
      for (size_t v = 0; v < pos->count; ++v) {
        if (uv_of[v] >= 0) lightmap_uv[v] = vertex_uv[size_t(uv_of[v])];
      }
    } else {
      lightmap_uv = vertex_uv;
      PENUMBRA_TRY(splitVertices(prim, vertex, index, role));
    }
    // The lightmap's UV set: the first free one, at least 1.
    int set = 0;
    while (attributes.contains(fmt::format("TEXCOORD_{}", set))) ++set;
    const int uv_accessor = at_.addAccessor(
        {{"bufferView", at_.addView(std::string(reinterpret_cast<const char*>(lightmap_uv.data()),
                                                lightmap_uv.size() * sizeof(glm::vec2)),
                                    0, kArrayBuffer)},
         {"componentType", kFloat},
         {"count", lightmap_uv.size()},
         {"type", "VEC2"}});
    if (set == 0) attributes["TEXCOORD_0"] = uv_accessor;
    set = std::max(set, 1);
    attributes[fmt::format("TEXCOORD_{}", set)] = uv_accessor;
    return set;
  }

  // Attributes and morph targets gathered for the new vertices, the indices a triangle list.
  Status splitVertices(json& prim, const std::vector<uint32_t>& vertex,
                       const std::vector<uint32_t>& index, const std::string& role) {
    auto regather = [&](json& attrs, const std::string& what) -> Status {
      for (auto it = attrs.begin(); it != attrs.end(); ++it) {
        Expected<int> g =
            at_.gatherFrom(*reader_, it.value().get<int>(), vertex, what + " " + it.key());
        if (!g) return g.error();
        it.value() = *g;
      }
      return {};
    };
    PENUMBRA_TRY(regather(prim["attributes"], role));
    if (prim.contains("targets")) {
      for (size_t t = 0; t < prim["targets"].size(); ++t) {
        PENUMBRA_TRY(regather(prim["targets"][t], fmt::format("{} target {}", role, t)));
      }
    }
    std::string bytes;
    const bool wide = vertex.size() > 65535;
    for (uint32_t i : index) {
      if (wide) {
        bytes.append(reinterpret_cast<const char*>(&i), 4);
      } else {
        const uint16_t s = uint16_t(i);
        bytes.append(reinterpret_cast<const char*>(&s), 2);
      }
    }
    prim["indices"] = at_.addAccessor({{"bufferView", at_.addView(bytes, 0, kElementArrayBuffer)},
                                       {"componentType", wide ? kUnsignedInt : kUnsignedShort},
                                       {"count", index.size()},
                                       {"type", "SCALAR"}});
    prim["mode"] = 4;
    return {};
  }

  // The material that says where the primitive's lightmap is: its own, a default one when it
  // has none, or a copy when the material already serves another UV set.
  int materialFor(int material, int set) {
    if (material < 0) {
      if (default_material_ < 0) {
        if (!j_.contains("materials")) j_["materials"] = json::array();
        j_["materials"].push_back(
            {{"name", "default"},
             {"pbrMetallicRoughness",
              {{"baseColorFactor", {0.8, 0.8, 0.8, 1.0}}, {"metallicFactor", 0.0}}}});
        default_material_ = int(j_["materials"].size()) - 1;
      }
      material = default_material_;
    }
    auto known = material_set_.find(material);
    if (known == material_set_.end()) {
      material_set_[material] = set;
      return material;
    }
    if (known->second == set) return material;
    auto copy = material_copy_.find({material, set});
    if (copy == material_copy_.end()) {
      j_["materials"].push_back(j_["materials"][size_t(material)]);
      const int index = int(j_["materials"].size()) - 1;
      material_set_[index] = set;
      copy = material_copy_.emplace(std::make_pair(material, set), index).first;
    }
    return copy->second;
  }

  GltfDocument& doc_;
  json& j_;
  Attacher at_;
  GltfDocument originals_;
  std::unique_ptr<Attacher> reader_;
  std::map<InstanceKey, std::vector<glm::vec2>> instances_;
  std::map<InstanceKey, std::vector<uint32_t>> corners_;
  std::map<int, int> mesh_owner_;                     // mesh -> the node that lightmaps it
  std::map<std::pair<int, int>, int> copies_;         // (node, mesh) -> the node's copy
  std::map<int, int> material_set_;                   // material -> its lightmap UV set
  std::map<std::pair<int, int>, int> material_copy_;  // (material, set) -> its copy
  int default_material_ = -1;
};

}  // namespace

Status writeLightmappedGltf(GltfDocument doc, std::span<const GltfTriangleSource> sources,
                            std::span<const TriangleLightmapUvs> uvs, const LightmapReference& lm,
                            const nlohmann::json& penumbra_extras, const std::string& gltf_path,
                            const std::string& bin_uri) {
  PENUMBRA_CHECK(sources.size() == uvs.size());
  LightmapWriter writer(doc, gltf_path);
  PENUMBRA_TRY(writer.collect(sources, uvs));
  PENUMBRA_TRY(writer.mergeBuffers());
  PENUMBRA_TRY(writer.attachAll());
  const std::string bin = writer.finish(lm, penumbra_extras, bin_uri);
  const std::string text = doc.json.dump(2) + "\n";
  const std::string bin_path = (fs::path(gltf_path).parent_path() / bin_uri).string();
  PENUMBRA_TRY(writeAtomically(
      bin_path, [&](const std::string& tmp) { return writeBytesTo(bin_path, tmp, bin); }));
  return writeAtomically(
      gltf_path, [&](const std::string& tmp) { return writeBytesTo(gltf_path, tmp, text); });
}

}  // namespace penumbra
