#include "penumbra/raytrace/gpu_cutouts.h"

#include "penumbra/core/memory.h"
#include "penumbra/gpu/storage.h"

#include <fmt/format.h>

#include <map>
#include <tuple>

namespace penumbra {

GpuCutoutData buildGpuCutouts(const SurfaceTextures& textures, size_t triangle_count) {
  GpuCutoutData out;
  out.triangle_cutout.assign(triangle_count, kNoCutout);
  // One stored channel per (texture, channel, sampler).
  using Key = std::tuple<const Texture*, int, TextureWrap, TextureWrap, bool>;
  std::map<Key, uint32_t> stored;
  const auto textureIndex = [&](const TextureBinding& binding, int channel) {
    const Texture& tex = *binding.texture;
    const TextureSampler& s = binding.sampler;
    const Key key{&tex, channel, s.wrap_s, s.wrap_t, s.nearest};
    if (auto it = stored.find(key); it != stored.end()) return it->second;
    const uint32_t index = uint32_t(out.textures.size());
    out.textures.push_back(
        {uint32_t(out.texels.size()), uint32_t(tex.width()), uint32_t(tex.height()),
         uint32_t(s.wrap_s) | (uint32_t(s.wrap_t) << 2) | (s.nearest ? 16u : 0u)});
    out.texels.reserve(out.texels.size() + size_t(tex.width()) * size_t(tex.height()));
    for (int y = 0; y < tex.height(); ++y) {
      for (int x = 0; x < tex.width(); ++x) out.texels.push_back(tex.fetch(0, x, y)[channel]);
    }
    stored.emplace(key, index);
    return index;
  };
  for (size_t t = 0; t < triangle_count; ++t) {
    const uint32_t tri = uint32_t(t);
    if (!textures.isCutout(tri)) continue;
    const SurfaceTextures::CutoutSource src = textures.cutoutSource(tri);
    const Material& m = textures.material(tri);
    GpuCutout g{};
    for (int j = 0; j < 2; ++j) {
      const SurfaceTextures::CutoutSource::Lookup& l = src.lookups[j];
      g.texture[j] = l.binding ? textureIndex(*l.binding, l.channel) : kNoCutout;
      for (int c = 0; c < 3; ++c) {
        g.st[6 * j + 2 * c] = l.st[c].x;
        g.st[6 * j + 2 * c + 1] = l.st[c].y;
      }
    }
    for (int c = 0; c < 3; ++c) g.factor[c] = src.factor[c];
    g.cutoff = m.alpha_mode == AlphaMode::kMask ? m.alpha_cutoff : -1.0f;
    out.triangle_cutout[t] = uint32_t(out.cutouts.size());
    out.cutouts.push_back(g);
  }
  return out;
}

std::string cutoutDefine(unsigned first_binding) {
  return fmt::format("CUTOUT_SSBO_FIRST {}", first_binding);
}

Expected<GlCutouts> GlCutouts::create(const GpuCutoutData& data, const char* place) {
  GLint64 max_ssbo = 0;
  glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &max_ssbo);
  const std::pair<const char*, uint64_t> needs[] = {
      {"cut-out index", data.triangle_cutout.size() * 4},
      {"cut-out triangle", data.cutouts.size() * sizeof(GpuCutout)},
      {"cut-out texel", data.texels.size() * 4}};
  for (const auto& [what, bytes] : needs) {
    if (bytes > uint64_t(max_ssbo)) {
      return inputError(
          "", place,
          fmt::format("the {} buffer needs {} bytes ({}), but this device allows {} "
                      "per shader storage block (GL_MAX_SHADER_STORAGE_BLOCK_SIZE)",
                      what, bytes, formatBytes(bytes), formatBytes(uint64_t(max_ssbo))));
    }
  }
  GlCutouts g;
  g.triangle_cutout_ = gl::storageBuffer(data.triangle_cutout);
  g.cutouts_ = gl::storageBuffer(data.cutouts);
  g.textures_ = gl::storageBuffer(data.textures);
  g.texels_ = gl::storageBuffer(data.texels);
  g.bytes_ = data.bytes();
  return g;
}

void GlCutouts::bind(unsigned first_binding) const {
  triangle_cutout_.bindBase(GL_SHADER_STORAGE_BUFFER, first_binding);
  cutouts_.bindBase(GL_SHADER_STORAGE_BUFFER, first_binding + 1);
  textures_.bindBase(GL_SHADER_STORAGE_BUFFER, first_binding + 2);
  texels_.bindBase(GL_SHADER_STORAGE_BUFFER, first_binding + 3);
}

}  // namespace penumbra
