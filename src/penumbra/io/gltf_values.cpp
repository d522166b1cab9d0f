#include "penumbra/io/gltf_values.h"

#include "penumbra/io/json_guard.h"

#include <fmt/format.h>

#include <cmath>
#include <initializer_list>
#include <limits>

namespace penumbra {

namespace {

using nlohmann::json;

constexpr double kInf = std::numeric_limits<double>::infinity();

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
  Status integer(const char* key, int64_t lo = 0) const {
    if (!obj_.contains(key)) return {};
    const json& v = obj_.at(key);
    if (!v.is_number_integer() || v.get<int64_t>() < lo) {
      return inputError(path_, at(key),
                        fmt::format("must be an integer >= {}, not {}", lo, describe(v)));
    }
    return {};
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
      if (!v[i].is_number_integer() || v[i].get<int64_t>() < 0) {
        return inputError(path_, fmt::format("{}[{}]", at(key), i),
                          fmt::format("must be an integer >= 0, not {}", describe(v[i])));
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

 private:
  Status checkNumber(const json& v, const std::string& place, double lo, double hi) const {
    if (!v.is_number()) {
      return inputError(path_, place, fmt::format("must be a number, not {}", describe(v)));
    }
    const double d = v.get<double>();
    if (!std::isfinite(d)) return inputError(path_, place, "must be a finite number");
    if (d < lo || d > hi) {
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
    PENUMBRA_TRY(check(Values(path, list[i], item), list[i]));
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

}  // namespace

Status checkGltfValues(const std::string& path, const json& root) {
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
