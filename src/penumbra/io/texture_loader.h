// Textures as the scene readers load them, planned before any is decoded (design doc sec. 5):
//   1. reserveFiles: the bytes of every image file the scene's materials read, against the
//      memory available, before any is read;
//   2. plan: each image's header (io/image_decode.h) and what its texture will take, an image
//      shared by several slots counted once per kind (colour, data, normal map);
//   3. checkPlan: all of it together against the memory available;
//   4. texture / dataImage: decoded on first use, shared by every slot that reads it.
// In a dry run (TextureOptions::decode false) step 4 decodes no colour or data texture: it hands
// out a 1 x 1 texture of mid grey in place of each planned image, so that the run's own plan can
// go on. Normal maps are decoded (their size sets the lightmap's density, and so the plan).
// Errors name the scene file, the material and slot, and the image.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/io/image_decode.h"
#include "penumbra/scene/texture.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace penumbra {

struct TextureOptions {
  ImageLimits limits;  // the largest side kept (--max-texture-size) and the decoders' budgets
  bool decode = true;  // false for --dry-run
};

// How a slot reads an image: sRGB colour, data as stored (masks), or a normal map (an Image of
// values in [0, 1]).
enum class TextureKind : uint8_t { kColour, kData, kNormalMap };

class TextureCache {
 public:
  explicit TextureCache(TextureOptions options = {});

  // Step 1: `bytes` of `count` image files are about to be read.
  Status reserveFiles(uint64_t bytes, size_t count, const std::string& scene_file);
  // Step 2: image `name`, whose bytes the caller keeps until it is decoded, read as `kind`.
  Status plan(const std::string& name, std::string_view bytes, TextureKind kind,
              const std::string& scene_file, const std::string& place);
  // Step 3.
  Status checkPlan(const std::string& scene_file);
  // Step 4: the planned image `name` as a texture (colour or data) or a normal map.
  Expected<std::shared_ptr<const Texture>> texture(const std::string& name, bool colour,
                                                   const std::string& scene_file,
                                                   const std::string& place);
  Expected<std::shared_ptr<const Image>> dataImage(const std::string& name,
                                                   const std::string& scene_file,
                                                   const std::string& place);

  // Reads, plans and checks the image file at `path` (steps 1-3 for one image, for loaders that
  // name files as they go: each new file is checked with everything planned before it).
  Status planFile(const std::string& path, TextureKind kind, const std::string& scene_file,
                  const std::string& place);
  // planFile, then texture(): the texture in the file at `path`.
  Expected<std::shared_ptr<const Texture>> file(const std::string& path, bool colour,
                                                const std::string& scene_file,
                                                const std::string& place);
  Expected<std::shared_ptr<const Image>> normalMapFile(const std::string& path,
                                                       const std::string& scene_file,
                                                       const std::string& place);

  // Warnings about what was planned or decoded (images reduced to the size limit).
  const std::vector<std::string>& warnings() const { return warnings_; }

 private:
  struct Planned {
    std::string_view bytes;
    ImageHeader header;
    ImagePlan plan;
    std::shared_ptr<const Texture> texture;
    std::shared_ptr<const Image> image;
  };
  using Key = std::pair<std::string, TextureKind>;
  Expected<Planned*> planned(const std::string& name, TextureKind kind,
                             const std::string& scene_file, const std::string& place);

  TextureOptions options_;
  std::map<Key, Planned> planned_;
  std::map<std::string, std::unique_ptr<std::string>> files_;  // bytes read by planFile
  uint64_t file_bytes_ = 0;
  std::vector<std::string> warnings_;
};

// KHR_texture_transform's "offset" and "scale" (two numbers each, within 1e6) and "rotation"
// (radians, within 1e6) from `spec` (the glTF extension's object, or a JSON scene's texture slot,
// which uses the same names) into the binding's transform; errors name `file` and `place`.
Status readTextureTransform(const nlohmann::json& spec, const std::string& file,
                            const std::string& place, TextureBinding& binding);

}  // namespace penumbra
