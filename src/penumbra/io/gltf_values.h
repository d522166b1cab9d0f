// The values of a glTF document checked against glTF 2.0's schema on the JSON, before the reader
// (io/gltf/) uses any: types, lengths, ranges and enumerations, so that nothing of the wrong shape
// is read as a default (a baseColorFactor of three numbers or a string as white, a node matrix of
// strings as the identity, a string wrapS as REPEAT).
#pragma once

#include "penumbra/core/expected.h"

#include <nlohmann/json.hpp>

#include <string>

namespace penumbra {

// Materials (the PBR factors, alpha, texture references), nodes (matrix, translation, rotation,
// scale, mesh, camera, children), cameras and KHR_lights_punctual lights: each value present has
// the type, length and range the glTF 2.0 schema gives it, and every number is finite. The error
// names `path` and the value ("materials[2].pbrMetallicRoughness.baseColorFactor").
Status checkGltfValues(const std::string& path, const nlohmann::json& root);

}  // namespace penumbra
