// Scene loading. Every loader returns a validated Scene in world space, or an Error naming the
// file and the place in it. Polygons are fan-triangulated (v0 v1 v2, v0 v2 v3, ...) and triangle
// i is the i-th triangle in file order.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/io/asset_files.h"
#include "penumbra/io/texture_loader.h"
#include "penumbra/scene/scene.h"

#include <nlohmann/json_fwd.hpp>

#include <functional>
#include <string>

namespace penumbra {

// How scene files are read: which files an asset may name, the textures' limits, a glTF file's
// scene.
struct SceneLoadOptions {
  AssetPolicy files;        // --allow-outside-files
  TextureOptions textures;  // --max-texture-size; no decoding in a dry run
  int gltf_scene = -1;      // --gltf-scene: a glTF file's scene (-1: its `scene`, else the first)
};

// Wavefront OBJ with its MTL (Kd -> reflectance, Ke -> emission), through tinyobjloader; the
// material libraries and textures it names are read from its own folder (SceneLoadOptions).
Expected<Scene> loadObj(const std::string& path, const SceneLoadOptions& options = {});
// glTF 2.0 (.gltf, .glb; io/gltf/): meshes with node transforms, skins and morph targets, the
// compression and material extensions (docs/scene-format.md), KHR_lights_punctual lights, the
// first camera.
Expected<Scene> loadGltf(const std::string& path, const SceneLoadOptions& options = {});
// PLY, ASCII and binary (either byte order), read in file order.
Expected<Scene> loadPly(const std::string& path);
// The same from the file's bytes (`path` names it in messages and gives the mesh its name).
Expected<Scene> loadPlyBytes(const std::string& path, const std::string& bytes);
// Penumbra's JSON scene format (docs/scene-format.md); paths relative to the scene file.
Expected<Scene> loadSceneJson(const std::string& path, const SceneLoadOptions& options = {});
// The same from the file's text: messages name `path`, and files it names are found relative to
// it (to the working directory when `path` names no file). `complete`, when given, adds to the
// scene (meshes held in memory) before it is validated as a whole.
Expected<Scene> parseSceneJson(const std::string& path, const std::string& text,
                               const std::function<void(Scene&)>& complete = {},
                               const SceneLoadOptions& options = {});

// The "settings" object of a JSON scene file (null when the file has none, is not a .json file
// or cannot be read: loading it reports that). Cheap: the meshes are not read.
nlohmann::json readSceneSettings(const std::string& path);

// By extension: .json, .obj, .gltf, .glb, .ply.
Expected<Scene> loadSceneFile(const std::string& path, const SceneLoadOptions& options = {});

// A built-in scene name or a file path.
Expected<Scene> loadScene(const std::string& name_or_path, const SceneLoadOptions& options = {});
// The built-in `sss` scene (io/builtin_sss.cpp): the bunny in marble, lit from behind and the
// side.
Expected<Scene> sssBuiltinScene();
// The built-in `lpv` scene: the same bunny in marble lit from behind by one point light.
Expected<Scene> lpvBuiltinScene();

}  // namespace penumbra
