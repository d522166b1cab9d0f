// Textures as the scene readers load them: each image decoded once per scene and shared by every
// material slot that reads it, errors naming the material, the slot and the image.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/scene/texture.h"

#include <nlohmann/json.hpp>

#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <utility>

namespace penumbra {

class TextureCache {
 public:
  // The texture in the file at `path`; `colour` for colour (sRGB-encoded) images, false for
  // data (masks). On failure the error is the scene file's (`scene_file`), at `place` (the
  // material and slot), naming the image.
  Expected<std::shared_ptr<const Texture>> file(const std::string& path, bool colour,
                                                const std::string& scene_file,
                                                const std::string& place);
  // An image held inside the scene file (a glTF buffer view or data URI), named `name` (for
  // messages and sharing).
  Expected<std::shared_ptr<const Texture>> bytes(const std::string& name, std::string_view bytes,
                                                 bool colour, const std::string& scene_file,
                                                 const std::string& place);

 private:
  std::map<std::pair<std::string, bool>, std::shared_ptr<const Texture>> cache_;
};

// KHR_texture_transform's "offset" and "scale" (two numbers each, within 1e6) and "rotation"
// (radians, within 1e6) from `spec` (the glTF extension's object, or a JSON scene's texture slot,
// which uses the same names) into the binding's transform; errors name `file` and `place`.
Status readTextureTransform(const nlohmann::json& spec, const std::string& file,
                            const std::string& place, TextureBinding& binding);

}  // namespace penumbra
