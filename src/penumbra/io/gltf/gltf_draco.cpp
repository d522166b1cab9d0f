#include "penumbra/io/gltf/gltf_draco.h"

#include "penumbra/core/memory.h"
#include "penumbra/io/gltf/gltf_asset.h"

#include <draco/compression/decode.h>
#include <draco/mesh/mesh.h>
#include <nlohmann/json.hpp>

#include <fmt/format.h>

#include <cstring>
#include <exception>
#include <memory>

namespace penumbra {

namespace {

using nlohmann::json;

// The decoded values of `att` for every point of `mesh`, as `count` elements of `components`
// values of type T (the glTF accessor's componentType): Draco converts, normalizing integers
// when the attribute is normalized and T is float.
template <typename T>
bool convertAttribute(const draco::Mesh& mesh, const draco::PointAttribute& att, int components,
                      std::string& out) {
  const size_t points = mesh.num_points();
  out.assign(points * size_t(components) * sizeof(T), '\0');
  T value[16];
  for (uint32_t p = 0; p < points; ++p) {
    const draco::AttributeValueIndex avi = att.mapped_index(draco::PointIndex(p));
    if (avi.value() >= att.size()) return false;
    if (!att.ConvertValue<T>(avi, int8_t(components), value)) return false;
    std::memcpy(out.data() + size_t(p) * size_t(components) * sizeof(T), value,
                size_t(components) * sizeof(T));
  }
  return true;
}

bool convert(const draco::Mesh& mesh, const draco::PointAttribute& att, int components, int type,
             std::string& out) {
  switch (type) {
    case kGltfByte:
      return convertAttribute<int8_t>(mesh, att, components, out);
    case kGltfUnsignedByte:
      return convertAttribute<uint8_t>(mesh, att, components, out);
    case kGltfShort:
      return convertAttribute<int16_t>(mesh, att, components, out);
    case kGltfUnsignedShort:
      return convertAttribute<uint16_t>(mesh, att, components, out);
    case kGltfUnsignedInt:
      return convertAttribute<uint32_t>(mesh, att, components, out);
    default:
      return convertAttribute<float>(mesh, att, components, out);
  }
}

Expected<std::unique_ptr<draco::Mesh>> decodeStream(std::string_view bytes, const std::string& file,
                                                    const std::string& place) {
  try {
    draco::DecoderBuffer buffer;
    buffer.Init(bytes.data(), bytes.size());
    draco::Decoder decoder;
    draco::StatusOr<std::unique_ptr<draco::Mesh>> mesh = decoder.DecodeMeshFromBuffer(&buffer);
    if (!mesh.ok() || !mesh.value()) {
      return inputError(
          file, place,
          fmt::format("the Draco stream cannot be decoded: {}",
                      mesh.ok() ? "it holds no mesh" : mesh.status().error_msg_string()));
    }
    return std::move(mesh).value();
  } catch (const std::bad_alloc&) {
    return inputError(file, place,
                      "the Draco stream claims more than the memory available: refused as "
                      "malformed");
  } catch (const std::exception& e) {
    return inputError(file, place, fmt::format("the Draco stream cannot be decoded: {}", e.what()));
  }
}

}  // namespace

Expected<DracoPrimitive> decodeDracoPrimitive(GltfAsset& asset, const json& prim, const json& ext,
                                              const std::string& where) {
  const std::string& file = asset.path();
  const std::string place = where + ".extensions.KHR_draco_mesh_compression";
  if (!ext.is_object() || !ext.contains("bufferView") || !ext["bufferView"].is_number_integer() ||
      !ext.contains("attributes") || !ext["attributes"].is_object()) {
    return inputError(file, place, "needs an integer bufferView and an attributes object");
  }
  Expected<std::string_view> bytes = asset.bufferView(ext["bufferView"].get<int64_t>(), place);
  if (!bytes) return bytes.error();
  Expected<std::unique_ptr<draco::Mesh>> decoded = decodeStream(*bytes, file, place);
  if (!decoded) return decoded.error();
  const draco::Mesh& mesh = **decoded;
  DracoPrimitive out;
  const json& attributes = prim.at("attributes");
  for (auto it = ext["attributes"].begin(); it != ext["attributes"].end(); ++it) {
    const std::string name = it.key();
    const std::string at = place + ".attributes." + name;
    if (!it->is_number_integer() || !attributes.contains(name)) {
      return inputError(file, at, "must be an integer naming one of the primitive's attributes");
    }
    const draco::PointAttribute* att = mesh.GetAttributeByUniqueId(it->get<uint32_t>());
    Expected<const json*> accessor = asset.entry("accessors", attributes[name].get<int64_t>(), at);
    if (!accessor) return accessor.error();
    const json& a = **accessor;
    const int components = componentCount(a.value("type", std::string()));
    const int type = a.value("componentType", kGltfFloat);
    if (!att || components == 0 || att->num_components() < components) {
      return inputError(
          file, at,
          fmt::format("Draco attribute {} {}", it->get<int64_t>(),
                      att ? "has fewer components than its accessor" : "is not in the stream"));
    }
    if (a.value("count", uint64_t(0)) != mesh.num_points()) {
      return inputError(file, at,
                        fmt::format("the Draco stream decodes {} points, its accessor claims {}",
                                    mesh.num_points(), a.value("count", uint64_t(0))));
    }
    PENUMBRA_TRY(checkMemory(uint64_t(mesh.num_points()) * uint64_t(components) * 4,
                             fmt::format("{}: {}", file, at)));
    std::string values;
    if (!convert(mesh, *att, components, type, values)) {
      return inputError(file, at, "the Draco attribute's values do not fit its accessor's type");
    }
    const bool normalized = type != kGltfFloat && a.value("normalized", false);
    out.attributes[name] =
        denseAccessor(std::move(values), mesh.num_points(), components, type, normalized);
  }
  std::string indices(size_t(mesh.num_faces()) * 3 * 4, '\0');
  for (uint32_t f = 0; f < mesh.num_faces(); ++f) {
    const draco::Mesh::Face& face = mesh.face(draco::FaceIndex(f));
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = face[k].value();
      std::memcpy(indices.data() + (size_t(f) * 3 + size_t(k)) * 4, &v, 4);
    }
  }
  if (prim.contains("indices")) {
    Expected<const json*> accessor =
        asset.entry("accessors", prim["indices"].get<int64_t>(), where + " indices");
    if (!accessor) return accessor.error();
    if ((*accessor)->value("count", uint64_t(0)) != uint64_t(mesh.num_faces()) * 3) {
      return inputError(file, place,
                        fmt::format("the Draco stream decodes {} triangles, the indices accessor "
                                    "claims {} indices",
                                    mesh.num_faces(), (*accessor)->value("count", uint64_t(0))));
    }
  }
  out.indices =
      denseAccessor(std::move(indices), size_t(mesh.num_faces()) * 3, 1, kGltfUnsignedInt, false);
  return out;
}

}  // namespace penumbra
