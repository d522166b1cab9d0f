#include "penumbra/io/texture_loader.h"

#include "penumbra/io/image_io.h"

#include <fmt/format.h>

namespace penumbra {

namespace {

Expected<std::shared_ptr<const Texture>> makeTexture(const std::string& name,
                                                     Expected<TextureTexels> texels, bool colour,
                                                     const std::string& scene_file,
                                                     const std::string& place) {
  if (!texels) {
    // The image's own error, moved to the material that reads it.
    const Error& e = texels.error();
    Error out = inputError(scene_file, place, fmt::format("image '{}': {}", name, e.message));
    out.kind = e.kind;
    return out;
  }
  TextureTexels& t = *texels;
  Texture texture =
      t.sixteen_bit
          ? Texture::fromRgba16(name, t.width, t.height, t.rgba16, colour, t.channels)
          : Texture::fromRgba8(name, t.width, t.height, std::move(t.rgba8), colour, t.channels);
  return std::make_shared<const Texture>(std::move(texture));
}

}  // namespace

Expected<std::shared_ptr<const Texture>> TextureCache::file(const std::string& path, bool colour,
                                                            const std::string& scene_file,
                                                            const std::string& place) {
  auto it = cache_.find({path, colour});
  if (it != cache_.end()) return it->second;
  Expected<std::shared_ptr<const Texture>> t =
      makeTexture(path, readTextureImage(path), colour, scene_file, place);
  if (t) cache_[{path, colour}] = *t;
  return t;
}

Expected<std::shared_ptr<const Texture>> TextureCache::bytes(const std::string& name,
                                                             std::string_view bytes, bool colour,
                                                             const std::string& scene_file,
                                                             const std::string& place) {
  auto it = cache_.find({name, colour});
  if (it != cache_.end()) return it->second;
  Expected<std::shared_ptr<const Texture>> t =
      makeTexture(name, decodeTextureImage(name, bytes), colour, scene_file, place);
  if (t) cache_[{name, colour}] = *t;
  return t;
}

}  // namespace penumbra
