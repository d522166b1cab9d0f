// Cut-outs on the GPU: what every GPU pass that decides visibility (the GL Ray Engine's
// kernel, the hemispherical depth pass of progressive and stochastic radiosity) needs to answer
// "does this hit stop here" exactly as the CPU's hit filter does (raytrace/cutout_filter.h,
// scene/surface_textures.h stops()): per cut-out triangle its alpha sources, and the coverage
// textures' finest level as the CPU reads it, in shader storage buffers read by
// shaders/common/cutout.glsl. The shader reproduces the CPU's sampling (bilinear or nearest,
// the three wrap modes, texel centres at half-integers) on the same texel values, so CPU and GPU
// agree texel for texel; a partly covering (kBlend) hit decides with the same hash of the ray as
// the CPU (rayHashUniform) where a ray exists, and with a hash of the fragment in raster passes.
//
// Needs a current OpenGL context (gpu/context.h) for GlCutouts.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/gpu/objects.h"
#include "penumbra/scene/surface_textures.h"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace penumbra {

// ---- std430 layouts, mirrored in shaders/common/cutout.glsl ----

struct GpuCutout {      // 80 bytes: a cut-out triangle's alpha sources
  float st[12];         // lookups 0 and 1, corners 0-2: image coordinates (s, t)
  float factor[3];      // alpha factor at the corners
  float cutoff;         // kMask: stops where alpha >= cutoff; negative for kBlend
  uint32_t texture[2];  // the lookups' GpuCutoutTexture, ~0u for none
  uint32_t pad[2];
};
static_assert(sizeof(GpuCutout) == 80 && offsetof(GpuCutout, factor) == 48 &&
              offsetof(GpuCutout, texture) == 64);

struct GpuCutoutTexture {  // 16 bytes: one channel of a texture's finest level
  uint32_t first;          // its first value in the texel buffer (row-major, row 0 at the top)
  uint32_t width;
  uint32_t height;
  uint32_t mode;  // wrap_s | wrap_t << 2 | nearest << 4 (TextureWrap values)
};
static_assert(sizeof(GpuCutoutTexture) == 16);

inline constexpr uint32_t kNoCutout = 0xffffffffu;

// The buffers' contents, built on the CPU.
struct GpuCutoutData {
  std::vector<uint32_t> triangle_cutout;  // per triangle: its GpuCutout, or kNoCutout
  std::vector<GpuCutout> cutouts;
  std::vector<GpuCutoutTexture> textures;
  std::vector<float> texels;  // the channels' values, as Texture::fetch gives them

  uint64_t bytes() const {
    return triangle_cutout.size() * 4 + cutouts.size() * sizeof(GpuCutout) +
           textures.size() * sizeof(GpuCutoutTexture) + texels.size() * 4;
  }
};

// Over `triangle_count` triangles (flattenScene order) of a scene whose SurfaceTextures has
// cut-outs. A texture's channel under one sampler is stored once, whichever triangles read it.
GpuCutoutData buildGpuCutouts(const SurfaceTextures& textures, size_t triangle_count);

// The #define that places the four buffers at binding points first .. first + 3 and turns the
// test on (shaders/common/cutout.glsl).
std::string cutoutDefine(unsigned first_binding);

class GlCutouts {
 public:
  // Uploads the data. Fails as an input error naming the bytes when a buffer exceeds the
  // device's shader storage block size; `place` names the caller in it.
  static Expected<GlCutouts> create(const GpuCutoutData& data, const char* place);

  GlCutouts() = default;
  // Binds the buffers at first .. first + 3 (the binding of cutoutDefine).
  void bind(unsigned first_binding) const;
  uint64_t deviceBytes() const { return bytes_; }

 private:
  gl::Buffer triangle_cutout_, cutouts_, textures_, texels_;
  uint64_t bytes_ = 0;
};

}  // namespace penumbra
