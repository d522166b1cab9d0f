#include "penumbra/io/gltf_values.h"

#include "penumbra/io/json_guard.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cmath>
#include <initializer_list>
#include <limits>

namespace penumbra {

namespace {

using nlohmann::json;

constexpr double kInf = std::numeric_limits<double>::infinity();
// The largest index into one of the document's arrays, and the largest byte count or offset
// (glTF 2.0 sec. 3.6.1: JSON numbers are exact integers up to 2^53).
constexpr int64_t kMaxIndex = (int64_t(1) << 31) - 1;
constexpr int64_t kMaxBytes = int64_t(1) << 53;

// An integer within int64 (nlohmann holds integers above 2^63 as unsigned).
bool isInteger(const json& v) {
  return v.is_number_integer() &&
         (!v.is_number_unsigned() || v.get<uint64_t>() <= uint64_t(kMaxBytes));
}

// What a JSON value is, for messages: an array with its length, a number as written.
std::string describe(const json& j) {
  if (j.is_array()) return fmt::format("an array of {}", j.size());
  if (j.is_number()) return j.dump();
  return jsonTypeName(j);
}

// Checks the values of one object of the document; each check passes when the key is absent
// (glTF's defaults apply) and otherwise requires the schema's type, length and range.
class Values {
 public:
  Values(const std::string& path, const json& obj, std::string place)
      : path_(path), obj_(obj), place_(std::move(place)) {}

  Status number(const char* key, double lo = -kInf, double hi = kInf) const {
    if (!obj_.contains(key)) return {};
    return checkNumber(obj_.at(key), at(key), lo, hi);
  }
  // An integer in [lo, hi]; indices into the document's arrays stay below 2^31.
  Status integer(const char* key, int64_t lo = 0, int64_t hi = kMaxIndex) const {
    if (!obj_.contains(key)) return {};
    const json& v = obj_.at(key);
    if (!isInteger(v) || v.get<int64_t>() < lo || v.get<int64_t>() > hi) {
      return inputError(
          path_, at(key),
          fmt::format("must be an integer from {} to {}, not {}", lo, hi, describe(v)));
    }
    return {};
  }
  // An integer that must be present.
  Status required(const char* key, int64_t lo = 0, int64_t hi = kMaxIndex) const {
    if (!obj_.contains(key)) return inputError(path_, at(key), "is missing");
    return integer(key, lo, hi);
  }
  // An integer of `allowed` (an enumeration: componentType, sampler filters and wraps).
  Status oneOf(const char* key, std::initializer_list<int64_t> allowed) const {
    if (!obj_.contains(key)) return {};
    const json& v = obj_.at(key);
    if (isInteger(v)) {
      for (int64_t a : allowed) {
        if (v.get<int64_t>() == a) return {};
      }
    }
    return inputError(
        path_, at(key),
        fmt::format("must be one of {}, not {}", fmt::join(allowed, ", "), describe(v)));
  }
  // A string of `allowed`.
  Status word(const char* key, std::initializer_list<const char*> allowed) const {
    if (!obj_.contains(key)) return {};
    const json& v = obj_.at(key);
    if (v.is_string()) {
      for (const char* a : allowed) {
        if (v.get<std::string>() == a) return {};
      }
    }
    return inputError(path_, at(key),
                      fmt::format("must be one of {}, not {}", fmt::join(allowed, ", "),
                                  v.is_string() ? "'" + v.get<std::string>() + "'" : describe(v)));
  }
  Status numbers(const char* key, size_t n, double lo = -kInf, double hi = kInf) const {
    if (!obj_.contains(key)) return {};
    const json& v = obj_.at(key);
    if (!v.is_array() || v.size() != n) {
      return inputError(path_, at(key),
                        fmt::format("must be an array of {} numbers, not {}", n, describe(v)));
    }
    for (size_t i = 0; i < n; ++i) {
      PENUMBRA_TRY(checkNumber(v[i], fmt::format("{}[{}]", at(key), i), lo, hi));
    }
    return {};
  }
  Status integers(const char* key) const {
    if (!obj_.contains(key)) return {};
    const json& v = obj_.at(key);
    if (!v.is_array()) {
      return inputError(path_, at(key),
                        fmt::format("must be an array of integers, not {}", describe(v)));
    }
    for (size_t i = 0; i < v.size(); ++i) {
      if (!isInteger(v[i]) || v[i].get<int64_t>() < 0 || v[i].get<int64_t>() > kMaxIndex) {
        return inputError(
            path_, fmt::format("{}[{}]", at(key), i),
            fmt::format("must be an integer from 0 to {}, not {}", kMaxIndex, describe(v[i])));
      }
    }
    return {};
  }
  Status boolean(const char* key) const {
    if (!obj_.contains(key) || obj_.at(key).is_boolean()) return {};
    return inputError(path_, at(key),
                      fmt::format("must be true or false, not {}", describe(obj_.at(key))));
  }
  Status string(const char* key) const {
    if (!obj_.contains(key) || obj_.at(key).is_string()) return {};
    return inputError(path_, at(key),
                      fmt::format("must be a string, not {}", describe(obj_.at(key))));
  }
  // The object under `key`, checked to be one; null when absent.
  Expected<const json*> object(const char* key) const {
    if (!obj_.contains(key)) return static_cast<const json*>(nullptr);
    const json& v = obj_.at(key);
    if (!v.is_object()) {
      return inputError(path_, at(key), fmt::format("must be an object, not {}", describe(v)));
    }
    return &v;
  }
  std::string at(const char* key) const { return place_.empty() ? key : place_ + "." + key; }
  const std::string& place() const { return place_; }

 private:
  Status checkNumber(const json& v, const std::string& place, double lo, double hi) const {
    if (!v.is_number()) {
      return inputError(path_, place, fmt::format("must be a number, not {}", describe(v)));
    }
    const double d = v.get<double>();
    if (!std::isfinite(d)) return inputError(path_, place, "must be a finite number");
    // A bound missed by float32 rounding (1.00000012, written from a float that was 1 after
    // arithmetic) is the bound: the reader clamps. Beyond that the value is refused.
    if (d < lo - 1e-6 * std::abs(lo) || d > hi + 1e-6 * std::abs(hi)) {
      return inputError(path_, place,
                        hi == kInf ? fmt::format("{} is below {}", v.dump(), lo)
                                   : fmt::format("{} is outside [{}, {}]", v.dump(), lo, hi));
    }
    return {};
  }

  const std::string& path_;
  const json& obj_;
  std::string place_;
};

// Each element of the top-level array `key` that is an object, with its place ("nodes[3]").
template <typename F>
Status eachObject(const std::string& path, const json& parent, const char* key,
                  const std::string& place, F&& check) {
  if (!parent.contains(key)) return {};
  const json& list = parent.at(key);
  const std::string where = place.empty() ? key : place + "." + key;
  if (!list.is_array()) {
    return inputError(path, where, fmt::format("must be an array, not {}", describe(list)));
  }
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string item = fmt::format("{}[{}]", where, i);
    if (!list[i].is_object()) {
      return inputError(path, item, fmt::format("must be an object, not {}", describe(list[i])));
    }
    const Values values(path, list[i], item);
    PENUMBRA_TRY(values.string("name"));
    PENUMBRA_TRY(check(values, list[i]));
  }
  return {};
}

// A textureInfo (glTF 2.0, sec. 5.50) and its KHR_texture_transform.
Status checkTextureInfo(const std::string& path, const Values& parent, const char* key) {
  Expected<const json*> info = parent.object(key);
  if (!info) return info.error();
  if (!*info) return {};
  const Values v(path, **info, parent.at(key));
  PENUMBRA_TRY(v.integer("index"));
  PENUMBRA_TRY(v.integer("texCoord"));
  PENUMBRA_TRY(v.number("scale"));               // normalTextureInfo
  PENUMBRA_TRY(v.number("strength", 0.0, 1.0));  // occlusionTextureInfo
  Expected<const json*> ext = v.object("extensions");
  if (!ext) return ext.error();
  if (!*ext) return {};
  const Values e(path, **ext, v.at("extensions"));
  Expected<const json*> transform = e.object("KHR_texture_transform");
  if (!transform) return transform.error();
  if (!*transform) return {};
  const Values t(path, **transform, e.at("KHR_texture_transform"));
  PENUMBRA_TRY(t.numbers("offset", 2));
  PENUMBRA_TRY(t.numbers("scale", 2));
  PENUMBRA_TRY(t.number("rotation"));
  return t.integer("texCoord");
}

// glTF 2.0, sec. 5.19 (material) and 5.22 (pbrMetallicRoughness).
Status checkMaterial(const std::string& path, const Values& m) {
  PENUMBRA_TRY(m.numbers("emissiveFactor", 3, 0.0));
  PENUMBRA_TRY(m.string("alphaMode"));
  PENUMBRA_TRY(m.number("alphaCutoff", 0.0));
  PENUMBRA_TRY(m.boolean("doubleSided"));
  for (const char* t : {"normalTexture", "occlusionTexture", "emissiveTexture"}) {
    PENUMBRA_TRY(checkTextureInfo(path, m, t));
  }
  Expected<const json*> pbr = m.object("pbrMetallicRoughness");
  if (!pbr) return pbr.error();
  if (!*pbr) return {};
  const Values p(path, **pbr, m.at("pbrMetallicRoughness"));
  PENUMBRA_TRY(p.numbers("baseColorFactor", 4, 0.0, 1.0));
  PENUMBRA_TRY(p.number("metallicFactor", 0.0, 1.0));
  PENUMBRA_TRY(p.number("roughnessFactor", 0.0, 1.0));
  PENUMBRA_TRY(checkTextureInfo(path, p, "baseColorTexture"));
  return checkTextureInfo(path, p, "metallicRoughnessTexture");
}

// glTF 2.0, sec. 5.25 (node): a matrix or TRS, never strings read as the identity.
Status checkNode(const Values& n) {
  PENUMBRA_TRY(n.numbers("matrix", 16));
  PENUMBRA_TRY(n.numbers("translation", 3));
  PENUMBRA_TRY(n.numbers("rotation", 4, -1.0, 1.0));
  PENUMBRA_TRY(n.numbers("scale", 3));
  PENUMBRA_TRY(n.integer("mesh"));
  PENUMBRA_TRY(n.integer("camera"));
  PENUMBRA_TRY(n.integer("skin"));
  return n.integers("children");
}

// glTF 2.0, sec. 5.12-5.14 (camera, orthographic, perspective).
Status checkCamera(const std::string& path, const Values& c) {
  PENUMBRA_TRY(c.string("type"));
  Expected<const json*> persp = c.object("perspective");
  if (!persp) return persp.error();
  if (*persp) {
    const Values p(path, **persp, c.at("perspective"));
    PENUMBRA_TRY(p.number("yfov", 1e-9, 3.1415926535));
    PENUMBRA_TRY(p.number("aspectRatio", 1e-9));
    PENUMBRA_TRY(p.number("znear", 0.0));
    PENUMBRA_TRY(p.number("zfar", 0.0));
  }
  Expected<const json*> ortho = c.object("orthographic");
  if (!ortho) return ortho.error();
  if (*ortho) {
    const Values o(path, **ortho, c.at("orthographic"));
    for (const char* k : {"xmag", "ymag", "zfar", "znear"}) PENUMBRA_TRY(o.number(k));
  }
  return {};
}

// KHR_lights_punctual: color, intensity, range and the spot's cone angles.
Status checkPunctualLight(const std::string& path, const Values& l) {
  PENUMBRA_TRY(l.string("type"));
  PENUMBRA_TRY(l.numbers("color", 3, 0.0, 1.0));
  PENUMBRA_TRY(l.number("intensity", 0.0));
  PENUMBRA_TRY(l.number("range", 0.0));
  Expected<const json*> spot = l.object("spot");
  if (!spot) return spot.error();
  if (!*spot) return {};
  const Values s(path, **spot, l.at("spot"));
  PENUMBRA_TRY(s.number("innerConeAngle", 0.0, 1.5707963268));
  return s.number("outerConeAngle", 0.0, 1.5707963268);
}

// glTF 2.0 sec. 5.1 (accessor) and 5.2-5.5 (sparse): the layout of every accessor, so that no
// size read later can overflow.
Status checkAccessor(const std::string& path, const Values& a) {
  PENUMBRA_TRY(a.integer("bufferView"));
  PENUMBRA_TRY(a.integer("byteOffset", 0, kMaxBytes));
  PENUMBRA_TRY(a.oneOf("componentType", {5120, 5121, 5122, 5123, 5125, 5126}));
  PENUMBRA_TRY(a.boolean("normalized"));
  PENUMBRA_TRY(a.required("count", 1, kMaxBytes));
  PENUMBRA_TRY(a.word("type", {"SCALAR", "VEC2", "VEC3", "VEC4", "MAT2", "MAT3", "MAT4"}));
  Expected<const json*> sparse = a.object("sparse");
  if (!sparse) return sparse.error();
  if (!*sparse) return {};
  const Values sp(path, **sparse, a.at("sparse"));
  PENUMBRA_TRY(sp.required("count", 1, kMaxBytes));
  for (const char* part : {"indices", "values"}) {
    Expected<const json*> o = sp.object(part);
    if (!o) return o.error();
    if (!*o) return inputError(path, sp.at(part), "is missing");
    const Values v(path, **o, sp.at(part));
    PENUMBRA_TRY(v.required("bufferView"));
    PENUMBRA_TRY(v.integer("byteOffset", 0, kMaxBytes));
    if (std::string(part) == "indices") {
      if (!(*o)->contains("componentType"))
        return inputError(path, v.at("componentType"), "is missing");
      PENUMBRA_TRY(v.oneOf("componentType", {5121, 5123, 5125}));
    }
  }
  return {};
}

// sec. 5.10-5.11 (buffer, bufferView), 5.17 (image), 5.26 (sampler), 5.29 (texture).
Status checkBufferView(const Values& v) {
  PENUMBRA_TRY(v.required("buffer"));
  PENUMBRA_TRY(v.integer("byteOffset", 0, kMaxBytes));
  PENUMBRA_TRY(v.required("byteLength", 1, kMaxBytes));
  PENUMBRA_TRY(v.integer("byteStride", 4, 252));
  return v.oneOf("target", {34962, 34963});
}
Status checkBuffer(const Values& b) {
  PENUMBRA_TRY(b.string("uri"));
  return b.required("byteLength", 1, kMaxBytes);
}
Status checkImage(const Values& i) {
  PENUMBRA_TRY(i.string("uri"));
  PENUMBRA_TRY(i.string("mimeType"));
  return i.integer("bufferView");
}
Status checkSampler(const Values& s) {
  PENUMBRA_TRY(s.oneOf("magFilter", {9728, 9729}));
  PENUMBRA_TRY(s.oneOf("minFilter", {9728, 9729, 9984, 9985, 9986, 9987}));
  PENUMBRA_TRY(s.oneOf("wrapS", {33071, 33648, 10497}));
  return s.oneOf("wrapT", {33071, 33648, 10497});
}
Status checkTexture(const std::string& path, const Values& t) {
  PENUMBRA_TRY(t.integer("sampler"));
  PENUMBRA_TRY(t.integer("source"));
  Expected<const json*> ext = t.object("extensions");
  if (!ext) return ext.error();
  if (!*ext) return {};
  for (auto it = (*ext)->begin(); it != (*ext)->end(); ++it) {
    // Every image extension (KHR_texture_basisu, EXT_texture_webp, EXT_texture_avif, ...) names
    // its image as "source".
    const std::string where = t.at("extensions") + "." + it.key();
    if (!it->is_object()) return inputError(path, where, "must be an object");
    PENUMBRA_TRY(Values(path, *it, where).integer("source"));
  }
  return {};
}

// sec. 5.24: a morph target names its accessors by attribute.
Status checkTarget(const Values& t, const json& target) {
  for (auto it = target.begin(); it != target.end(); ++it) {
    PENUMBRA_TRY(t.required(it.key().c_str()));
  }
  return {};
}

// sec. 5.24 (primitive): attributes, indices, material, mode and morph targets.
Status checkPrimitive(const std::string& path, const Values& p, const json& j) {
  PENUMBRA_TRY(p.integer("indices"));
  PENUMBRA_TRY(p.integer("material"));
  PENUMBRA_TRY(p.integer("mode", 0, 6));
  Expected<const json*> attributes = p.object("attributes");
  if (!attributes) return attributes.error();
  if (!*attributes) return inputError(path, p.at("attributes"), "is missing");
  const Values a(path, **attributes, p.at("attributes"));
  for (auto it = (*attributes)->begin(); it != (*attributes)->end(); ++it) {
    PENUMBRA_TRY(a.required(it.key().c_str()));
  }
  if (!j.contains("targets")) return {};
  return eachObject(path, j, "targets", p.place(), checkTarget);
}

// sec. 5.23 (mesh).
Status checkMesh(const std::string& path, const Values& m, const json& mesh) {
  if (!mesh.contains("primitives")) return inputError(path, m.at("primitives"), "is missing");
  const Status primitives =
      eachObject(path, mesh, "primitives", m.place(),
                 [&](const Values& p, const json& j) { return checkPrimitive(path, p, j); });
  if (!primitives) return primitives;
  if (!mesh.contains("weights")) return {};
  if (!mesh.at("weights").is_array()) {
    return inputError(path, m.at("weights"), "must be an array of numbers");
  }
  return m.numbers("weights", mesh.at("weights").size());
}

// sec. 5.28 (skin).
Status checkSkin(const Values& s) {
  PENUMBRA_TRY(s.integer("inverseBindMatrices"));
  PENUMBRA_TRY(s.integer("skeleton"));
  return s.integers("joints");
}

// A top-level array of strings ("extensionsUsed").
Status checkStrings(const std::string& path, const json& root, const char* key) {
  if (!root.contains(key)) return {};
  const json& list = root.at(key);
  if (!list.is_array()) return inputError(path, key, "must be an array of strings");
  for (size_t i = 0; i < list.size(); ++i) {
    if (!list[i].is_string()) {
      return inputError(path, fmt::format("{}[{}]", key, i),
                        fmt::format("must be a string, not {}", describe(list[i])));
    }
  }
  return {};
}

Status checkStructure(const std::string& path, const json& root) {
  PENUMBRA_TRY(checkStrings(path, root, "extensionsUsed"));
  PENUMBRA_TRY(checkStrings(path, root, "extensionsRequired"));
  PENUMBRA_TRY(eachObject(path, root, "accessors", "",
                          [&](const Values& a, const json&) { return checkAccessor(path, a); }));
  PENUMBRA_TRY(eachObject(path, root, "bufferViews", "",
                          [&](const Values& v, const json&) { return checkBufferView(v); }));
  PENUMBRA_TRY(eachObject(path, root, "buffers", "",
                          [&](const Values& b, const json&) { return checkBuffer(b); }));
  PENUMBRA_TRY(eachObject(path, root, "images", "",
                          [&](const Values& i, const json&) { return checkImage(i); }));
  PENUMBRA_TRY(eachObject(path, root, "samplers", "",
                          [&](const Values& s, const json&) { return checkSampler(s); }));
  PENUMBRA_TRY(eachObject(path, root, "textures", "",
                          [&](const Values& t, const json&) { return checkTexture(path, t); }));
  PENUMBRA_TRY(eachObject(path, root, "meshes", "",
                          [&](const Values& m, const json& j) { return checkMesh(path, m, j); }));
  PENUMBRA_TRY(eachObject(path, root, "scenes", "",
                          [&](const Values& s, const json&) { return s.integers("nodes"); }));
  PENUMBRA_TRY(eachObject(path, root, "skins", "",
                          [&](const Values& s, const json&) { return checkSkin(s); }));
  return Values(path, root, "").integer("scene");
}

}  // namespace

Status checkGltfValues(const std::string& path, const json& root) {
  PENUMBRA_TRY(checkStructure(path, root));
  PENUMBRA_TRY(eachObject(path, root, "materials", "",
                          [&](const Values& m, const json&) { return checkMaterial(path, m); }));
  PENUMBRA_TRY(eachObject(path, root, "nodes", "",
                          [&](const Values& n, const json&) { return checkNode(n); }));
  PENUMBRA_TRY(eachObject(path, root, "cameras", "",
                          [&](const Values& c, const json&) { return checkCamera(path, c); }));
  const Values top(path, root, "");
  Expected<const json*> ext = top.object("extensions");
  if (!ext) return ext.error();
  if (!*ext) return {};
  const Values e(path, **ext, "extensions");
  Expected<const json*> lights = e.object("KHR_lights_punctual");
  if (!lights) return lights.error();
  if (!*lights) return {};
  return eachObject(path, **lights, "lights", "extensions.KHR_lights_punctual",
                    [&](const Values& l, const json&) { return checkPunctualLight(path, l); });
}

}  // namespace penumbra
