#include "penumbra/io/gltf/gltf_primitive.h"

#include "penumbra/io/gltf/gltf_accessor.h"
#include "penumbra/io/gltf/gltf_asset.h"
#include "penumbra/io/gltf/gltf_draco.h"
#include "penumbra/io/gltf_common.h"

#include <nlohmann/json.hpp>

#include <fmt/format.h>

#include <cmath>
#include <optional>

namespace penumbra {

namespace {

using nlohmann::json;

bool finite3(const glm::dvec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// Reads a primitive's attributes: from the Draco stream when it holds them, else from their
// accessors.
class AttributeReader {
 public:
  AttributeReader(GltfAsset& asset, const json& attributes, std::optional<DracoPrimitive>& draco,
                  std::string where)
      : asset_(asset), attributes_(attributes), draco_(draco), where_(std::move(where)) {}

  // The accessor of attribute `name` read for `use` (null when the primitive has none), with
  // `count` elements when count > 0.
  Expected<std::optional<AccessorView>> get(const std::string& name, const std::string& use,
                                            size_t count) {
    if (!attributes_.contains(name)) return std::optional<AccessorView>();
    const int64_t index = attributes_[name].get<int64_t>();
    const std::string role = where_ + " " + name;
    std::optional<AccessorView> view;
    if (draco_ && draco_->attributes.count(name)) {
      PENUMBRA_TRY(checkAccessorUse(asset_, index, use, role));
      view = draco_->attributes.at(name);
    } else {
      Expected<AccessorView> v = readAccessor(asset_, index, use, role);
      if (!v) return v.error();
      view = std::move(*v);
    }
    if (count > 0 && view->count != count) {
      return inputError(asset_.path(), fmt::format("accessor {} ({})", index, role),
                        fmt::format("count {} differs from POSITION's {}", view->count, count));
    }
    return view;
  }
  std::string place(const std::string& name) const {
    return fmt::format("accessor {} ({} {})", attributes_[name].get<int64_t>(), where_, name);
  }

 private:
  GltfAsset& asset_;
  const json& attributes_;
  std::optional<DracoPrimitive>& draco_;
  std::string where_;
};

// Reads a vec3 attribute. A position that is not finite refuses the file. A normal that is not
// finite (Blender's exporter has written NaN normals for degenerate faces, which the Khronos
// validator reports as ACCESSOR_INVALID_FLOAT) only shades: when `bad` is given it is read as zero,
// which shading takes as "use the triangle's own normal", and counted in *bad.
Status readVectors(GltfAsset& asset, AttributeReader& reader, const std::string& name,
                   const std::string& use, size_t count, std::vector<glm::dvec3>& out,
                   size_t* bad = nullptr) {
  Expected<std::optional<AccessorView>> v = reader.get(name, use, count);
  if (!v) return v.error();
  if (!*v) return {};
  const AccessorView& a = **v;
  out.resize(a.count);
  for (size_t i = 0; i < a.count; ++i) {
    out[i] = glm::dvec3(a.component(i, 0), a.component(i, 1), a.component(i, 2));
    if (!finite3(out[i]) && bad) {
      out[i] = glm::dvec3(0.0);
      ++*bad;
    } else if (!finite3(out[i])) {
      return inputError(asset.path(), fmt::format("{}, vertex {}", reader.place(name), i),
                        fmt::format("{} is not a finite number", name));
    }
  }
  return {};
}

Status readUvsAndColours(GltfAsset& asset, AttributeReader& reader, size_t n, PrimitiveData& d) {
  for (int set = 0; set < 8; ++set) {
    const std::string name = fmt::format("TEXCOORD_{}", set);
    Expected<std::optional<AccessorView>> v = reader.get(name, name, n);
    if (!v) return v.error();
    if (!*v) continue;
    if (d.uvs.size() <= size_t(set)) d.uvs.resize(size_t(set) + 1);
    std::vector<glm::vec2>& uvs = d.uvs[size_t(set)];
    uvs.resize(n);
    for (size_t i = 0; i < n; ++i) {
      const double u = (*v)->component(i, 0), w = (*v)->component(i, 1);
      if (!std::isfinite(u) || !std::isfinite(w) || std::abs(u) > 1e9 || std::abs(w) > 1e9) {
        return inputError(asset.path(), fmt::format("{}, vertex {}", reader.place(name), i),
                          "texture coordinate is not a finite number within 1e9");
      }
      uvs[i] = glm::vec2(float(u), float(w));
    }
  }
  Expected<std::optional<AccessorView>> c = reader.get("COLOR_0", "COLOR_0", n);
  if (!c) return c.error();
  if (!*c) return {};
  d.colors.resize(n);
  for (size_t i = 0; i < n; ++i) {
    glm::vec4 v(1.0f);
    for (int k = 0; k < (*c)->components; ++k) v[k] = float((*c)->component(i, k));
    if (!(v.x >= 0.0f && v.x <= 1.0f && v.y >= 0.0f && v.y <= 1.0f && v.z >= 0.0f && v.z <= 1.0f &&
          v.w >= 0.0f && v.w <= 1.0f)) {
      return inputError(asset.path(), fmt::format("{}, vertex {}", reader.place("COLOR_0"), i),
                        "colour is outside [0, 1]");
    }
    d.colors[i] = v;
  }
  return {};
}

Status readSkinAttributes(GltfAsset& asset, AttributeReader& reader, size_t n, PrimitiveData& d) {
  for (int set = 0; set < 2; ++set) {
    const std::string jn = fmt::format("JOINTS_{}", set), wn = fmt::format("WEIGHTS_{}", set);
    Expected<std::optional<AccessorView>> j = reader.get(jn, jn, n);
    if (!j) return j.error();
    Expected<std::optional<AccessorView>> w = reader.get(wn, wn, n);
    if (!w) return w.error();
    if (!*j || !*w) continue;
    d.joints[set].resize(n);
    d.weights[set].resize(n);
    for (size_t i = 0; i < n; ++i) {
      for (int k = 0; k < 4; ++k) {
        d.joints[set][i][k] = uint32_t((*j)->component(i, k));
        const double weight = (*w)->component(i, k);
        if (!(weight >= 0.0 && weight <= 1.0 + 1e-3)) {
          return inputError(asset.path(), fmt::format("{}, vertex {}", reader.place(wn), i),
                            "a skin weight is outside [0, 1]");
        }
        d.weights[set][i][k] = float(weight);
      }
    }
  }
  return {};
}

// glTF 2.0 sec. 3.7.2.2: the morphed attribute is the base plus the weighted sum of the targets'
// displacements.
Status applyMorphTargets(GltfAsset& asset, const json& prim, std::span<const double> weights,
                         const std::string& where, PrimitiveData& d) {
  if (!prim.contains("targets")) return {};
  const json& targets = prim["targets"];
  for (size_t t = 0; t < targets.size() && t < weights.size(); ++t) {
    const double w = weights[t];
    if (w == 0.0) continue;
    if (!std::isfinite(w)) {
      return inputError(asset.path(), where, fmt::format("morph weight {} is not finite", t));
    }
    std::optional<DracoPrimitive> none;
    AttributeReader reader(asset, targets[t], none, fmt::format("{} target {}", where, t));
    std::vector<glm::dvec3> delta;
    PENUMBRA_TRY(
        readVectors(asset, reader, "POSITION", "TARGET_POSITION", d.positions.size(), delta));
    for (size_t i = 0; i < delta.size(); ++i) d.positions[i] += w * delta[i];
    delta.clear();
    if (d.normals.empty()) continue;
    PENUMBRA_TRY(readVectors(asset, reader, "NORMAL", "TARGET_NORMAL", d.normals.size(), delta,
                             &d.bad_normals));
    for (size_t i = 0; i < delta.size(); ++i) d.normals[i] += w * delta[i];
  }
  return {};
}

Status readCorners(GltfAsset& asset, const json& prim, const std::optional<DracoPrimitive>& draco,
                   const std::string& where, PrimitiveData& d) {
  const size_t nv = d.positions.size();
  std::vector<uint32_t> seq;
  if (prim.contains("indices") || draco) {
    AccessorView idx;
    const int64_t index = prim.value("indices", int64_t(-1));
    if (draco) {
      idx = draco->indices;
    } else {
      Expected<AccessorView> v = readAccessor(asset, index, "indices", where + " indices");
      if (!v) return v.error();
      idx = std::move(*v);
    }
    seq.resize(idx.count);
    for (size_t i = 0; i < idx.count; ++i) {
      seq[i] = idx.index(i);
      if (seq[i] >= nv) {
        return inputError(asset.path(),
                          fmt::format("accessor {} ({} indices), element {}", index, where, i),
                          fmt::format("vertex index {} is out of range ({} vertices)", seq[i], nv));
      }
    }
  } else {
    seq.resize(nv);
    for (size_t i = 0; i < nv; ++i) seq[i] = uint32_t(i);
  }
  if (d.mode == 4) d.dropped = seq.size() % 3;
  d.corners = gltfTriangleCorners(d.mode, seq);
  return {};
}

}  // namespace

bool drawsTriangles(const json& prim) {
  const int mode = prim.value("mode", 4);
  return mode == 4 || mode == 5 || mode == 6;
}

Expected<PrimitiveData> readPrimitive(GltfAsset& asset, int64_t mesh, size_t primitive,
                                      std::span<const double> weights, const std::string& where) {
  const json& prim = asset.json()["meshes"][size_t(mesh)]["primitives"][primitive];
  PrimitiveData d;
  d.mode = prim.value("mode", 4);
  d.material = prim.value("material", int64_t(-1));
  const json& attributes = prim.at("attributes");
  if (!attributes.contains("POSITION")) {
    return inputError(asset.path(), where, "the primitive has no POSITION attribute");
  }
  std::optional<DracoPrimitive> draco;
  if (prim.contains("extensions") && prim["extensions"].contains("KHR_draco_mesh_compression")) {
    Expected<DracoPrimitive> decoded =
        decodeDracoPrimitive(asset, prim, prim["extensions"]["KHR_draco_mesh_compression"], where);
    if (!decoded) return decoded.error();
    draco = std::move(*decoded);
  }
  AttributeReader reader(asset, attributes, draco, where);
  PENUMBRA_TRY(readVectors(asset, reader, "POSITION", "POSITION", 0, d.positions));
  const size_t n = d.positions.size();
  PENUMBRA_TRY(readVectors(asset, reader, "NORMAL", "NORMAL", n, d.normals, &d.bad_normals));
  PENUMBRA_TRY(readUvsAndColours(asset, reader, n, d));
  PENUMBRA_TRY(readSkinAttributes(asset, reader, n, d));
  PENUMBRA_TRY(applyMorphTargets(asset, prim, weights, where, d));
  PENUMBRA_TRY(readCorners(asset, prim, draco, where, d));
  return d;
}

}  // namespace penumbra
