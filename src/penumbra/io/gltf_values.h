// The values of a glTF document that tinygltf drops without a word when their type or length is
// wrong (a baseColorFactor of three numbers or a string reads as white, a node matrix of strings
// as the identity), checked on the JSON against glTF 2.0's schema before tinygltf parses it.
#pragma once

#include "penumbra/core/expected.h"

#include <nlohmann/json.hpp>

#include <string>
#include <string_view>

namespace penumbra {

// Materials (the PBR factors, alpha, texture references), nodes (matrix, translation, rotation,
// scale, mesh, camera, children), cameras and KHR_lights_punctual lights: each value present has
// the type, length and range the glTF 2.0 schema gives it, and every number is finite. The error
// names `path` and the value ("materials[2].pbrMetallicRoughness.baseColorFactor").
Status checkGltfValues(const std::string& path, const nlohmann::json& root);

// The JSON chunk of a GLB file, after checking the header (glTF 2.0, sec. 4.4: magic, version
// 2, length, then a JSON chunk first); an input error naming `path` otherwise.
Expected<std::string_view> glbJsonChunk(const std::string& path, std::string_view bytes);

}  // namespace penumbra
