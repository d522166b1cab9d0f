#include "penumbra/io/gltf/gltf_accessor.h"

#include "penumbra/core/memory.h"
#include "penumbra/io/gltf/gltf_asset.h"

#include <nlohmann/json.hpp>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cstring>
#include <map>

namespace penumbra {

namespace {

using nlohmann::json;

const char* componentName(int component_type) {
  switch (component_type) {
    case kGltfByte:
      return "BYTE";
    case kGltfUnsignedByte:
      return "UNSIGNED_BYTE";
    case kGltfShort:
      return "SHORT";
    case kGltfUnsignedShort:
      return "UNSIGNED_SHORT";
    case kGltfUnsignedInt:
      return "UNSIGNED_INT";
    case kGltfFloat:
      return "FLOAT";
    default:
      return "an unknown componentType";
  }
}

std::string typeName(int components) {
  switch (components) {
    case 1:
      return "SCALAR";
    case 16:
      return "MAT4";
    default:
      return fmt::format("VEC{}", components);
  }
}

std::string storageName(const AccessorStorage& s) {
  return fmt::format("{}{}", componentName(s.component_type), s.normalized ? " normalized" : "");
}

bool contains(const std::vector<AccessorStorage>& list, int type, bool normalized) {
  for (const AccessorStorage& s : list) {
    if (s.component_type == type && s.normalized == normalized) return true;
  }
  return false;
}

bool usesQuantization(const json& root) {
  if (!root.contains("extensionsUsed") || !root["extensionsUsed"].is_array()) return false;
  for (const json& n : root["extensionsUsed"]) {
    if (n.is_string() && n.get<std::string>() == "KHR_mesh_quantization") return true;
  }
  return false;
}

// The storages of the rules (glTF 2.0 sec. 3.7.2.1; KHR_mesh_quantization "Extending Mesh
// Attributes" and "Extending Morph Target Attributes"; EXT_mesh_gpu_instancing).
constexpr AccessorStorage kF{kGltfFloat, false};
constexpr AccessorStorage kB{kGltfByte, false}, kBn{kGltfByte, true};
constexpr AccessorStorage kUb{kGltfUnsignedByte, false}, kUbn{kGltfUnsignedByte, true};
constexpr AccessorStorage kS{kGltfShort, false}, kSn{kGltfShort, true};
constexpr AccessorStorage kUs{kGltfUnsignedShort, false}, kUsn{kGltfUnsignedShort, true};
constexpr AccessorStorage kUi{kGltfUnsignedInt, false};

const std::map<std::string, AccessorRule>& rules() {
  static const std::map<std::string, AccessorRule> r = {
      {"POSITION", {{3}, {kF}, {kB, kBn, kUb, kUbn, kS, kSn, kUs, kUsn}}},
      {"NORMAL", {{3}, {kF}, {kBn, kSn}}},
      {"TANGENT", {{4}, {kF}, {kBn, kSn}}},
      {"TEXCOORD", {{2}, {kF, kUbn, kUsn}, {kB, kBn, kUb, kS, kSn, kUs}}},
      {"COLOR", {{3, 4}, {kF, kUbn, kUsn}, {}}},
      {"JOINTS", {{4}, {kUb, kUs}, {}}},
      {"WEIGHTS", {{4}, {kF, kUbn, kUsn}, {}}},
      {"TARGET_POSITION", {{3}, {kF}, {kB, kBn, kS, kSn}}},
      {"TARGET_NORMAL", {{3}, {kF}, {kBn, kSn}}},
      {"indices", {{1}, {kUb, kUs, kUi}, {}}},
      {"TRANSLATION", {{3}, {kF}, {kB, kBn, kS, kSn}}},
      {"ROTATION", {{4}, {kF, kBn, kSn}, {}}},
      {"SCALE", {{3}, {kF}, {kB, kBn, kS, kSn}}},
      {"inverseBindMatrices", {{16}, {kF}, {}}},
      // Any accessor, as it is (a sparse one written out densely).
      {"ANY", {{1, 2, 3, 4, 9, 16}, {kF, kB, kBn, kUb, kUbn, kS, kSn, kUs, kUsn, kUi}, {}}},
  };
  return r;
}

// Writes accessor `a`'s sparse substitution into `dense` (count elements of `element` bytes).
Status applySparse(GltfAsset& asset, const json& sparse, size_t count, size_t element,
                   std::string& dense, const std::string& place) {
  const uint64_t n = sparse.at("count").get<uint64_t>();
  if (n > count) {
    return inputError(asset.path(), place + ".sparse.count",
                      fmt::format("{} is more than the accessor's {} elements", n, count));
  }
  const json& indices = sparse.at("indices");
  const json& values = sparse.at("values");
  const int index_type = indices.at("componentType").get<int>();
  const size_t index_size = size_t(componentSize(index_type));
  auto range = [&](const json& part, size_t bytes, const char* what) -> Expected<const char*> {
    Expected<std::string_view> view =
        asset.bufferView(part.at("bufferView").get<int64_t>(), place + ".sparse." + what);
    if (!view) return view.error();
    const uint64_t offset = part.value("byteOffset", uint64_t(0));
    if (offset > view->size() || bytes > view->size() - offset) {
      return inputError(asset.path(), place + ".sparse." + what,
                        fmt::format("byteOffset {} + {} bytes run past the end of its buffer view "
                                    "({} bytes)",
                                    offset, bytes, view->size()));
    }
    return view->data() + offset;
  };
  Expected<const char*> idx = range(indices, size_t(n) * index_size, "indices");
  if (!idx) return idx.error();
  Expected<const char*> val = range(values, size_t(n) * element, "values");
  if (!val) return val.error();
  uint64_t previous = 0;
  for (size_t k = 0; k < n; ++k) {
    uint32_t i = 0;
    if (index_size == 1) {
      i = static_cast<unsigned char>((*idx)[k]);
    } else if (index_size == 2) {
      uint16_t v;
      std::memcpy(&v, *idx + 2 * k, 2);
      i = v;
    } else {
      std::memcpy(&i, *idx + 4 * k, 4);
    }
    if (i >= count || (k > 0 && i <= previous)) {
      return inputError(
          asset.path(), fmt::format("{}.sparse.indices, element {}", place, k),
          fmt::format("index {} must be below {} and above the one before", i, count));
    }
    previous = i;
    std::memcpy(dense.data() + size_t(i) * element, *val + k * element, element);
  }
  return {};
}

}  // namespace

int componentSize(int component_type) {
  switch (component_type) {
    case kGltfByte:
    case kGltfUnsignedByte:
      return 1;
    case kGltfShort:
    case kGltfUnsignedShort:
      return 2;
    case kGltfUnsignedInt:
    case kGltfFloat:
      return 4;
    default:
      return 0;
  }
}

int componentCount(const std::string& type) {
  if (type == "SCALAR") return 1;
  if (type == "VEC2") return 2;
  if (type == "VEC3") return 3;
  if (type == "VEC4" || type == "MAT2") return 4;
  if (type == "MAT3") return 9;
  if (type == "MAT4") return 16;
  return 0;
}

double AccessorView::component(size_t i, int c) const {
  const unsigned char* p = data + i * stride;
  switch (component_type) {
    case kGltfFloat: {
      float f;
      std::memcpy(&f, p + 4 * c, 4);
      return f;
    }
    case kGltfByte: {
      const double v = static_cast<int8_t>(p[c]);
      return normalized ? std::max(v / 127.0, -1.0) : v;
    }
    case kGltfUnsignedByte: {
      const double v = p[c];
      return normalized ? v / 255.0 : v;
    }
    case kGltfShort: {
      int16_t s;
      std::memcpy(&s, p + 2 * c, 2);
      return normalized ? std::max(s / 32767.0, -1.0) : double(s);
    }
    case kGltfUnsignedShort: {
      uint16_t v;
      std::memcpy(&v, p + 2 * c, 2);
      return normalized ? v / 65535.0 : double(v);
    }
    case kGltfUnsignedInt: {
      uint32_t v;
      std::memcpy(&v, p + 4 * c, 4);
      return v;
    }
    default:
      return 0.0;
  }
}

uint32_t AccessorView::index(size_t i) const {
  const unsigned char* p = data + i * stride;
  switch (component_type) {
    case kGltfUnsignedByte:
      return p[0];
    case kGltfUnsignedShort: {
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

const AccessorRule& accessorRule(const std::string& use) {
  const std::map<std::string, AccessorRule>& r = rules();
  auto it = r.find(use);
  if (it != r.end()) return it->second;
  // TEXCOORD_3, COLOR_0, JOINTS_1 ...: the rule of the set's name.
  const std::string base = use.substr(0, use.find('_'));
  it = r.find(base);
  return it != r.end() ? it->second : r.at("POSITION");
}

AccessorView denseAccessor(std::string bytes, size_t count, int components, int component_type,
                           bool normalized) {
  AccessorView v;
  auto owned = std::make_shared<const std::string>(std::move(bytes));
  v.data = reinterpret_cast<const unsigned char*>(owned->data());
  v.owned = std::move(owned);
  v.count = count;
  v.components = components;
  v.component_type = component_type;
  v.normalized = normalized;
  v.stride = size_t(components) * size_t(componentSize(component_type));
  return v;
}

Status checkAccessorUse(GltfAsset& asset, int64_t index, const std::string& use,
                        const std::string& role) {
  Expected<const json*> entry = asset.entry("accessors", index, role);
  if (!entry) return entry.error();
  const json& a = **entry;
  const std::string place = fmt::format("accessor {} ({})", index, role);
  const std::string& file = asset.path();
  const AccessorRule& rule = accessorRule(use);
  if (!a.contains("type") || !a.contains("componentType")) {
    return inputError(file, place, "type and componentType are required");
  }
  const int components = componentCount(a["type"].get<std::string>());
  if (std::find(rule.components.begin(), rule.components.end(), components) ==
      rule.components.end()) {
    return inputError(file, place,
                      fmt::format("type is {}, expected {}", a["type"].get<std::string>(),
                                  typeName(rule.components.front())));
  }
  const int type = a["componentType"].get<int>();
  const bool normalized = a.value("normalized", false);
  if (contains(rule.core, type, normalized)) return {};
  const AccessorStorage here{type, normalized};
  if (!contains(rule.quantized, type, normalized)) {
    std::vector<std::string> allowed;
    for (const AccessorStorage& s : rule.core) allowed.push_back(storageName(s));
    for (const AccessorStorage& s : rule.quantized) allowed.push_back(storageName(s));
    return inputError(file, place,
                      fmt::format("{} is not a storage {} takes ({})", storageName(here), use,
                                  fmt::join(allowed, ", ")));
  }
  if (!usesQuantization(asset.json())) {
    return inputError(file, place,
                      fmt::format("{} needs KHR_mesh_quantization, which the file does not list "
                                  "in extensionsUsed",
                                  storageName(here)));
  }
  return {};
}

Expected<AccessorView> readAccessor(GltfAsset& asset, int64_t index, const std::string& use,
                                    const std::string& role) {
  PENUMBRA_TRY(checkAccessorUse(asset, index, use, role));
  const json& a = asset.json()["accessors"][size_t(index)];
  const std::string place = fmt::format("accessor {} ({})", index, role);
  const std::string& file = asset.path();
  const int components = componentCount(a["type"].get<std::string>());
  const int type = a["componentType"].get<int>();
  const bool normalized = a.value("normalized", false);
  AccessorView v;
  v.count = a.at("count").get<size_t>();
  v.components = components;
  v.component_type = type;
  v.normalized = normalized;
  const size_t element = size_t(components) * size_t(componentSize(type));
  const uint64_t offset = a.value("byteOffset", uint64_t(0));
  std::string dense;
  if (!a.contains("bufferView") || a.contains("sparse")) {
    PENUMBRA_TRY(checkMemory(uint64_t(v.count) * element,
                             fmt::format("{}: {}'s {} elements", file, place, v.count)));
  }
  if (a.contains("bufferView")) {
    const int64_t view_index = a["bufferView"].get<int64_t>();
    Expected<std::string_view> view = asset.bufferView(view_index, place);
    if (!view) return view.error();
    const json& view_json = asset.json()["bufferViews"][size_t(view_index)];
    v.stride = view_json.value("byteStride", size_t(0));
    if (v.stride == 0) v.stride = element;
    if (v.stride < element) {
      return inputError(file, place,
                        fmt::format("byteStride {} of bufferView {} is smaller than an element "
                                    "({} bytes)",
                                    v.stride, view_index, element));
    }
    const size_t available = view->size();
    if (offset > available || element > available - offset ||
        (v.count - 1) > (available - offset - element) / v.stride) {
      return inputError(file, place,
                        fmt::format("byteOffset {} + {} elements of {} bytes (stride {}) run past "
                                    "the end of bufferView {} ({} bytes)",
                                    offset, v.count, element, v.stride, view_index, available));
    }
    v.data = reinterpret_cast<const unsigned char*>(view->data()) + offset;
    if (!a.contains("sparse")) return v;
    dense.resize(v.count * element);
    for (size_t i = 0; i < v.count; ++i) {
      std::memcpy(dense.data() + i * element, v.data + i * v.stride, element);
    }
  } else {
    dense.assign(v.count * element, '\0');  // glTF 2.0 sec. 3.6.2.3: no buffer view, all zeros
  }
  if (a.contains("sparse")) {
    PENUMBRA_TRY(applySparse(asset, a["sparse"], v.count, element, dense, place));
  }
  return denseAccessor(std::move(dense), v.count, components, type, normalized);
}

}  // namespace penumbra
