// readGltfDocument (io/gltf_lightmapped.h): a glTF asset as a plain document that any reader
// takes and that the lightmapped writer can add to. What Penumbra decoded is written out plainly:
//   - meshopt-compressed buffer views (EXT_/KHR_meshopt_compression) hold their decoded bytes,
//     and their fallback buffers go;
//   - Draco-compressed primitives (KHR_draco_mesh_compression) get plain accessors;
//   - sparse accessors are written densely;
//   - each copy of an EXT_mesh_gpu_instancing node becomes a child node of its own (each copy has
//     its own place in a lightmap), recorded in GltfDocument::instance_nodes;
//   - images a texture reads are kept (files are embedded by the writer), images none reads go;
// and those extensions leave extensionsUsed and extensionsRequired. Quantized accessors
// (KHR_mesh_quantization) stay as they are: three.js and Penumbra read them.
#include "penumbra/io/gltf/gltf_accessor.h"
#include "penumbra/io/gltf/gltf_asset.h"
#include "penumbra/io/gltf/gltf_draco.h"
#include "penumbra/io/gltf_lightmapped.h"

#include <nlohmann/json.hpp>

#include <glm/gtc/quaternion.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <set>

namespace penumbra {

namespace {

using nlohmann::json;

constexpr const char* kDecodedExtensions[] = {"EXT_meshopt_compression", "KHR_meshopt_compression",
                                              "KHR_draco_mesh_compression",
                                              "EXT_mesh_gpu_instancing"};

class PlainWriter {
 public:
  PlainWriter(GltfAsset& asset, GltfDocument& doc) : asset_(asset), doc_(doc), j_(doc.json) {}

  Status run() {
    doc_.buffers.assign(asset_.count("buffers") + 1, std::string());
    decoded_ = doc_.buffers.size() - 1;  // the last buffer holds what was decoded
    PENUMBRA_TRY(plainViews());
    PENUMBRA_TRY(plainDraco());
    PENUMBRA_TRY(plainSparse());
    PENUMBRA_TRY(expandInstances());
    PENUMBRA_TRY(keepUsedImages());
    dropExtensionNames();
    j_["buffers"].push_back({{"byteLength", doc_.buffers[decoded_].size()}});
    return {};
  }

 private:
  // Appends `bytes` to the decoded buffer as a view; its index.
  int64_t addView(std::string_view bytes, uint64_t stride = 0) {
    std::string& bin = doc_.buffers[decoded_];
    while (bin.size() % 4 != 0) bin.push_back('\0');
    json v = {{"buffer", decoded_}, {"byteOffset", bin.size()}, {"byteLength", bytes.size()}};
    if (stride) v["byteStride"] = stride;
    bin.append(bytes.data(), bytes.size());
    if (!j_.contains("bufferViews")) j_["bufferViews"] = json::array();
    j_["bufferViews"].push_back(std::move(v));
    return int64_t(j_["bufferViews"].size()) - 1;
  }

  Status plainViews() {
    if (!j_.contains("bufferViews")) return {};
    const size_t views = j_["bufferViews"].size();
    for (size_t v = 0; v < views; ++v) {
      json& view = j_["bufferViews"][v];
      const std::string where = fmt::format("bufferViews[{}]", v);
      json* ext = view.contains("extensions") ? &view["extensions"] : nullptr;
      const bool compressed = ext && (ext->contains("EXT_meshopt_compression") ||
                                      ext->contains("KHR_meshopt_compression"));
      if (!compressed) {
        const int64_t b = view.value("buffer", int64_t(0));
        if (doc_.buffers[size_t(b)].empty()) {
          Expected<std::string_view> bytes = asset_.buffer(b, where);
          if (!bytes) return bytes.error();
          doc_.buffers[size_t(b)] = std::string(*bytes);
        }
        continue;
      }
      Expected<std::string_view> bytes = asset_.bufferView(int64_t(v), where);
      if (!bytes) return bytes.error();
      std::string& bin = doc_.buffers[decoded_];
      while (bin.size() % 4 != 0) bin.push_back('\0');
      view["buffer"] = decoded_;
      view["byteOffset"] = bin.size();
      bin.append(bytes->data(), bytes->size());
      ext->erase("EXT_meshopt_compression");
      ext->erase("KHR_meshopt_compression");
      if (ext->empty()) view.erase("extensions");
    }
    for (json& b : j_.contains("buffers") ? j_["buffers"] : json::array()) {
      if (!b.contains("extensions")) continue;
      b["extensions"].erase("EXT_meshopt_compression");
      b["extensions"].erase("KHR_meshopt_compression");
      if (b["extensions"].empty()) b.erase("extensions");
    }
    return {};
  }

  Status plainDraco() {
    if (!j_.contains("meshes")) return {};
    for (size_t m = 0; m < j_["meshes"].size(); ++m) {
      json& prims = j_["meshes"][m]["primitives"];
      for (size_t p = 0; p < prims.size(); ++p) {
        json& prim = prims[p];
        if (!prim.contains("extensions") ||
            !prim["extensions"].contains("KHR_draco_mesh_compression")) {
          continue;
        }
        const std::string where = fmt::format("mesh {} primitive {}", m, p);
        Expected<DracoPrimitive> d = decodeDracoPrimitive(
            asset_, prim, prim["extensions"]["KHR_draco_mesh_compression"], where);
        if (!d) return d.error();
        for (auto& [name, view] : d->attributes) {
          json& a = j_["accessors"][size_t(prim["attributes"][name].get<int64_t>())];
          a["bufferView"] = addView(*view.owned);
          a.erase("byteOffset");
        }
        const int64_t indices = addView(*d->indices.owned);
        json index_accessor = {{"bufferView", indices},
                               {"componentType", kGltfUnsignedInt},
                               {"count", d->indices.count},
                               {"type", "SCALAR"}};
        if (prim.contains("indices")) {
          j_["accessors"][size_t(prim["indices"].get<int64_t>())] = index_accessor;
        } else {
          j_["accessors"].push_back(index_accessor);
          prim["indices"] = j_["accessors"].size() - 1;
        }
        prim["extensions"].erase("KHR_draco_mesh_compression");
        if (prim["extensions"].empty()) prim.erase("extensions");
      }
    }
    return {};
  }

  Status plainSparse() {
    if (!j_.contains("accessors")) return {};
    for (size_t a = 0; a < j_["accessors"].size(); ++a) {
      json& accessor = j_["accessors"][a];
      if (!accessor.contains("sparse")) continue;
      Expected<AccessorView> v =
          readAccessor(asset_, int64_t(a), "ANY", fmt::format("accessors[{}]", a));
      if (!v) return v.error();
      accessor["bufferView"] = addView(*v->owned);
      accessor.erase("byteOffset");
      accessor.erase("sparse");
    }
    return {};
  }

  Status expandInstances() {
    if (!j_.contains("nodes")) return {};
    const size_t nodes = j_["nodes"].size();
    for (size_t n = 0; n < nodes; ++n) {
      json& node = j_["nodes"][n];
      if (!node.contains("extensions") || !node["extensions"].contains("EXT_mesh_gpu_instancing")) {
        continue;
      }
      const json attributes =
          node["extensions"]["EXT_mesh_gpu_instancing"].value("attributes", json::object());
      std::map<std::string, AccessorView> views;
      size_t count = 0;
      for (const char* name : {"TRANSLATION", "ROTATION", "SCALE"}) {
        if (!attributes.contains(name)) continue;
        Expected<AccessorView> v = readAccessor(asset_, attributes[name].get<int64_t>(), name,
                                                fmt::format("node {} {}", n, name));
        if (!v) return v.error();
        count = v->count;
        views.emplace(name, std::move(*v));
      }
      for (size_t k = 0; k < count; ++k) {
        json child = {
            {"mesh", node["mesh"]},
            {"name", fmt::format("{}@{}", node.value("name", std::string("instance")), k)}};
        if (views.count("TRANSLATION")) {
          const AccessorView& t = views["TRANSLATION"];
          child["translation"] = {t.component(k, 0), t.component(k, 1), t.component(k, 2)};
        }
        if (views.count("ROTATION")) {
          const AccessorView& r = views["ROTATION"];
          glm::dquat q(r.component(k, 3), r.component(k, 0), r.component(k, 1), r.component(k, 2));
          q = glm::normalize(q);
          child["rotation"] = {q.x, q.y, q.z, q.w};
        }
        if (views.count("SCALE")) {
          const AccessorView& s = views["SCALE"];
          child["scale"] = {s.component(k, 0), s.component(k, 1), s.component(k, 2)};
        }
        if (node.contains("weights")) child["weights"] = node["weights"];
        j_["nodes"].push_back(std::move(child));
        const int64_t index = int64_t(j_["nodes"].size()) - 1;
        j_["nodes"][n]["children"].push_back(index);
        doc_.instance_nodes[{int(n), int(k)}] = int(index);
      }
      json& parent = j_["nodes"][n];
      parent.erase("mesh");
      parent["extensions"].erase("EXT_mesh_gpu_instancing");
      if (parent["extensions"].empty()) parent.erase("extensions");
    }
    return {};
  }

  // Images a texture reads (its source and its image extensions' sources) stay, renumbered;
  // the others go, unread.
  Status keepUsedImages() {
    if (!j_.contains("images")) return {};
    std::set<int64_t> used;
    auto each_source = [&](json& texture, auto&& f) {
      if (texture.contains("source")) f(texture["source"]);
      if (texture.contains("extensions")) {
        for (auto it = texture["extensions"].begin(); it != texture["extensions"].end(); ++it) {
          if (it->is_object() && it->contains("source")) f((*it)["source"]);
        }
      }
    };
    for (json& t : j_.contains("textures") ? j_["textures"] : json::array()) {
      each_source(t, [&](json& s) { used.insert(s.get<int64_t>()); });
    }
    std::map<int64_t, int64_t> renumber;
    json images = json::array();
    for (int64_t i : used) {
      Expected<const json*> image = asset_.entry("images", i, "textures");
      if (!image) return image.error();
      renumber[i] = int64_t(images.size());
      images.push_back(**image);
      const json& source = **image;
      if (source.contains("uri") && !isDataUri(source["uri"].get<std::string>())) {
        Expected<std::string_view> bytes = asset_.imageBytes(i, fmt::format("images[{}]", i));
        if (!bytes) return bytes.error();
        doc_.file_images.emplace_back(int(renumber[i]), std::string(*bytes));
      }
    }
    j_["images"] = std::move(images);
    for (json& t : j_.contains("textures") ? j_["textures"] : json::array()) {
      each_source(t, [&](json& s) { s = renumber[s.get<int64_t>()]; });
    }
    return {};
  }

  void dropExtensionNames() {
    for (const char* key : {"extensionsUsed", "extensionsRequired"}) {
      if (!j_.contains(key)) continue;
      json kept = json::array();
      for (const json& name : j_[key]) {
        const std::string n = name.get<std::string>();
        if (std::find(std::begin(kDecodedExtensions), std::end(kDecodedExtensions), n) ==
            std::end(kDecodedExtensions)) {
          kept.push_back(name);
        }
      }
      if (kept.empty()) {
        j_.erase(key);
      } else {
        j_[key] = std::move(kept);
      }
    }
  }

  GltfAsset& asset_;
  GltfDocument& doc_;
  json& j_;
  size_t decoded_ = 0;
};

}  // namespace

Expected<GltfDocument> readGltfDocument(const std::string& path, const AssetPolicy& policy) {
  Expected<GltfAsset> asset = GltfAsset::open(path, policy);
  if (!asset) return asset.error();
  GltfDocument doc;
  doc.path = path;
  doc.json = asset->json();
  if (!doc.json.contains("buffers")) doc.json["buffers"] = json::array();
  PlainWriter writer(*asset, doc);
  PENUMBRA_TRY(writer.run());
  return doc;
}

}  // namespace penumbra
