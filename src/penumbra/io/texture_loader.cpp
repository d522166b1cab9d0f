#include "penumbra/io/texture_loader.h"

#include "penumbra/core/file_util.h"
#include "penumbra/core/memory.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace penumbra {

namespace {

// A texture's error moved to the material that reads it.
Error atSlot(const Error& e, const std::string& name, const std::string& scene_file,
             const std::string& place) {
  const std::string message =
      e.file == name || e.file.empty() ? e.message : fmt::format("{}: {}", e.file, e.message);
  Error out = inputError(scene_file, place, fmt::format("image '{}': {}", name, message));
  out.kind = e.kind;
  return out;
}

}  // namespace

TextureCache::TextureCache(TextureOptions options) : options_(std::move(options)) {}

Status TextureCache::reserveFiles(uint64_t bytes, size_t count, const std::string& scene_file) {
  file_bytes_ += bytes;
  return checkMemory(file_bytes_, fmt::format("{}: reading the {} image files the materials use",
                                              scene_file, count));
}

Status TextureCache::plan(const std::string& name, std::string_view bytes, TextureKind kind,
                          const std::string& scene_file, const std::string& place) {
  const Key key{name, kind};
  if (planned_.count(key)) return {};
  Expected<ImageHeader> header = readImageHeader(name, bytes);
  if (!header) return atSlot(header.error(), name, scene_file, place);
  if (header->scans > options_.limits.max_scans) {
    return inputError(scene_file, place,
                      fmt::format("image '{}': the JPEG has {} scans, more than the {} Penumbra "
                                  "decodes (a progressive JPEG has about 10; each scan rereads the "
                                  "whole image)",
                                  name, header->scans, options_.limits.max_scans));
  }
  Planned p;
  p.bytes = bytes;
  p.header = *header;
  p.plan = kind == TextureKind::kNormalMap ? planDataImage(*header, options_.limits)
                                           : planImage(*header, options_.limits);
  planned_.emplace(key, std::move(p));
  return {};
}

Status TextureCache::checkPlan(const std::string& scene_file) {
  if (planned_.empty()) return {};
  // Every texture kept, and the largest transient of any one decode (plannedSceneBytes).
  std::vector<ImagePlan> plans;
  uint64_t kept = 0;
  for (const auto& [key, p] : planned_) {
    plans.push_back(p.plan);
    kept += p.plan.texture_bytes;
  }
  const uint64_t total = plannedSceneBytes(plans);
  return checkMemory(
      file_bytes_ + total,
      fmt::format("{}: the {} textures the materials use ({} decoded, {} while "
                  "decoding the largest)",
                  scene_file, planned_.size(), formatBytes(kept), formatBytes(total - kept)));
}

Expected<TextureCache::Planned*> TextureCache::planned(const std::string& name, TextureKind kind,
                                                       const std::string& scene_file,
                                                       const std::string& place) {
  auto it = planned_.find({name, kind});
  if (it == planned_.end()) {
    // A caller that did not plan this image: planned now, with everything planned before it.
    auto bytes = planned_.begin();
    while (bytes != planned_.end() && bytes->first.first != name) ++bytes;
    if (bytes == planned_.end()) {
      return runtimeError(scene_file, fmt::format("{}: image '{}' was not planned", place, name));
    }
    PENUMBRA_TRY(plan(name, bytes->second.bytes, kind, scene_file, place));
    PENUMBRA_TRY(checkPlan(scene_file));
    it = planned_.find({name, kind});
  }
  return &it->second;
}

Expected<std::shared_ptr<const Texture>> TextureCache::texture(const std::string& name, bool colour,
                                                               const std::string& scene_file,
                                                               const std::string& place) {
  const TextureKind kind = colour ? TextureKind::kColour : TextureKind::kData;
  Expected<Planned*> p = planned(name, kind, scene_file, place);
  if (!p) return p.error();
  Planned& planned = **p;
  if (planned.texture) return planned.texture;
  if (!options_.decode) {
    planned.texture = std::make_shared<const Texture>(
        Texture::fromRgba8(name, 1, 1, {128, 128, 128, 255}, colour, planned.header.channels));
    return planned.texture;
  }
  Expected<TextureTexels> texels = decodeTextureImage(name, planned.bytes, options_.limits);
  if (!texels) return atSlot(texels.error(), name, scene_file, place);
  TextureTexels& t = *texels;
  for (const std::string& w : t.warnings) {
    warnings_.push_back(fmt::format("{}: {}: image '{}': {}", scene_file, place, name, w));
  }
  planned.texture = std::make_shared<const Texture>(
      t.sixteen_bit
          ? Texture::fromRgba16(name, t.width, t.height, t.rgba16, colour, t.channels)
          : Texture::fromRgba8(name, t.width, t.height, std::move(t.rgba8), colour, t.channels));
  return planned.texture;
}

Expected<std::shared_ptr<const Image>> TextureCache::dataImage(const std::string& name,
                                                               const std::string& scene_file,
                                                               const std::string& place) {
  Expected<Planned*> p = planned(name, TextureKind::kNormalMap, scene_file, place);
  if (!p) return p.error();
  Planned& planned = **p;
  if (planned.image) return planned.image;
  // Decoded in a dry run too (planned and checked first): a normal map's size sets the automatic
  // lightmap density (radiosity/radiosity_surface.h), and so the plan the dry run checks.
  std::vector<std::string> warnings;
  Expected<Image> image = decodeDataImage(name, planned.bytes, options_.limits, &warnings);
  if (!image) return atSlot(image.error(), name, scene_file, place);
  for (const std::string& w : warnings) {
    warnings_.push_back(fmt::format("{}: {}: image '{}': {}", scene_file, place, name, w));
  }
  planned.image = std::make_shared<const Image>(std::move(*image));
  return planned.image;
}

Status TextureCache::planFile(const std::string& path, TextureKind kind,
                              const std::string& scene_file, const std::string& place) {
  auto it = files_.find(path);
  if (it == files_.end()) {
    Status size = checkInputFile(path);
    if (!size) return atSlot(size.error(), path, scene_file, place);
    Expected<std::string> bytes = readFile(path);
    if (!bytes) return atSlot(bytes.error(), path, scene_file, place);
    if (bytes->empty()) {
      return inputError(scene_file, place, fmt::format("image '{}': the file is empty", path));
    }
    file_bytes_ += bytes->size();
    it = files_.emplace(path, std::make_unique<std::string>(std::move(*bytes))).first;
  }
  PENUMBRA_TRY(plan(path, *it->second, kind, scene_file, place));
  return checkPlan(scene_file);
}

Expected<std::shared_ptr<const Texture>> TextureCache::file(const std::string& path, bool colour,
                                                            const std::string& scene_file,
                                                            const std::string& place) {
  PENUMBRA_TRY(
      planFile(path, colour ? TextureKind::kColour : TextureKind::kData, scene_file, place));
  return texture(path, colour, scene_file, place);
}

Expected<std::shared_ptr<const Image>> TextureCache::normalMapFile(const std::string& path,
                                                                   const std::string& scene_file,
                                                                   const std::string& place) {
  PENUMBRA_TRY(planFile(path, TextureKind::kNormalMap, scene_file, place));
  return dataImage(path, scene_file, place);
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
