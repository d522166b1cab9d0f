// KHR_draco_mesh_compression: a primitive whose indices and attributes are one Draco stream,
// decoded by Google's Draco library (Debian's libdraco-dev). The extension maps each glTF
// attribute to a Draco attribute id; the primitive's accessors keep their type, componentType,
// normalized flag and count, and have no buffer view. The decoded counts must match the
// accessors' (a stream that lies about its counts is refused), and every index must name a
// decoded point.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/io/gltf/gltf_accessor.h"

#include <nlohmann/json_fwd.hpp>

#include <map>
#include <string>

namespace penumbra {

class GltfAsset;

struct DracoPrimitive {
  std::map<std::string, AccessorView> attributes;  // by glTF attribute name
  AccessorView indices;                            // UNSIGNED_INT, three per triangle
};

// Decodes the extension object `ext` of primitive `prim`; `where` names the primitive
// ("mesh 0 primitive 1").
Expected<DracoPrimitive> decodeDracoPrimitive(GltfAsset& asset, const nlohmann::json& prim,
                                              const nlohmann::json& ext, const std::string& where);

}  // namespace penumbra
