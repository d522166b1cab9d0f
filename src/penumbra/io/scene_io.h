// Scene loading. Every loader returns a validated Scene in world space, or an Error naming the
// file and the place in it. Polygons are fan-triangulated (v0 v1 v2, v0 v2 v3, ...) and triangle
// i is the i-th triangle in file order.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/scene/scene.h"

#include <nlohmann/json_fwd.hpp>

#include <functional>
#include <string>

namespace penumbra {

// Wavefront OBJ with its MTL (Kd -> reflectance, Ke -> emission), through tinyobjloader.
Expected<Scene> loadObj(const std::string& path);
// glTF 2.0 (.gltf, .glb) through tinygltf: meshes with node transforms, PBR base colour ->
// reflectance, emissive (times KHR_materials_emissive_strength) -> emission,
// KHR_lights_punctual point/spot/directional lights, the first camera.
Expected<Scene> loadGltf(const std::string& path);
// PLY, ASCII and binary (either byte order), read in file order.
Expected<Scene> loadPly(const std::string& path);
// The same from the file's bytes (`path` names it in messages and gives the mesh its name).
Expected<Scene> loadPlyBytes(const std::string& path, const std::string& bytes);
// Penumbra's JSON scene format (docs/scene-format.md); paths relative to the scene file.
Expected<Scene> loadSceneJson(const std::string& path);
// The same from the file's text: messages name `path`, and files it names are found relative to
// it (to the working directory when `path` names no file). `complete`, when given, adds to the
// scene (meshes held in memory) before it is validated as a whole.
Expected<Scene> parseSceneJson(const std::string& path, const std::string& text,
                               const std::function<void(Scene&)>& complete = {});

// The "settings" object of a JSON scene file (null when the file has none, is not a .json file
// or cannot be read: loading it reports that). Cheap: the meshes are not read.
nlohmann::json readSceneSettings(const std::string& path);

// By extension: .json, .obj, .gltf, .glb, .ply.
Expected<Scene> loadSceneFile(const std::string& path);

// A built-in scene name or a file path.
Expected<Scene> loadScene(const std::string& name_or_path);
// The built-in `sss` scene (io/builtin_sss.cpp): the bunny in marble, lit from behind and the
// side.
Expected<Scene> sssBuiltinScene();
// The built-in `lpv` scene: the same bunny in marble lit from behind by one point light.
Expected<Scene> lpvBuiltinScene();

}  // namespace penumbra
