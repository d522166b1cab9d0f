#include "penumbra/io/texture_loader.h"

#include "penumbra/io/image_io.h"

#include <fmt/format.h>

#include <cmath>
#include <numbers>

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

Status readTextureTransform(const nlohmann::json& spec, const std::string& file,
                            const std::string& place, TextureBinding& binding) {
  auto pair = [&](const char* key, glm::vec2 fallback) -> Expected<glm::vec2> {
    if (!spec.contains(key)) return fallback;
    const nlohmann::json& v = spec.at(key);
    if (!v.is_array() || v.size() != 2 || !v[0].is_number() || !v[1].is_number()) {
      return inputError(file, place + "." + key, "must be two numbers");
    }
    const glm::dvec2 d(v[0].get<double>(), v[1].get<double>());
    if (!(std::abs(d.x) <= 1e6 && std::abs(d.y) <= 1e6)) {
      return inputError(file, place + "." + key, "must be finite, within 1e6");
    }
    return glm::vec2(d);
  };
  Expected<glm::vec2> offset = pair("offset", glm::vec2(0.0f));
  if (!offset) return offset.error();
  Expected<glm::vec2> scale = pair("scale", glm::vec2(1.0f));
  if (!scale) return scale.error();
  double rotation = 0.0;
  if (spec.contains("rotation")) {
    const nlohmann::json& r = spec.at("rotation");
    if (!r.is_number() || !(std::abs(r.get<double>()) <= 1e6)) {
      return inputError(file, place + ".rotation", "must be a number of radians within 1e6");
    }
    rotation = r.get<double>();
  }
  binding.setTransform(*offset, float(std::remainder(rotation, 2.0 * std::numbers::pi)), *scale);
  return {};
}

}  // namespace penumbra
