// Textures as materials use them (glTF 2.0 sec. 3.8 "Texture Data" and 3.9 "Materials"; MTL
// map_Kd, map_Ke, map_d): a decoded image with its mip pyramid, and a binding that says which UV
// set reads it, through which sampler and which transform (KHR_texture_transform, MTL -o/-s).
//
// Conventions (docs/scene-format.md):
//  - Texel values are linear. Colour textures (base colour, emission) are stored sRGB-encoded and
//    decoded by the sRGB transfer function at every fetch (IEC 61966-2-1), as a GPU's sRGB
//    formats do; data textures (cut-out masks) are stored and read as they are. Alpha is always
//    linear.
//  - Image coordinates (s, t): (0, 0) the top-left corner of the image, (1, 1) the bottom-right;
//    texel (x, y) covers [x, x+1] x [y, y+1] in texel units, its centre at (x + 1/2, y + 1/2).
//    A mesh's UVs become (s, t) through the binding's transform and the mesh's v axis
//    (Mesh::uv_origin_top).
//  - Level k of the pyramid is max(1, floor(w / 2^k)) x max(1, floor(h / 2^k)) (the OpenGL
//    rule), each texel the mean of the 2 x 2 (or, next to an odd edge, 3 x 2, 2 x 3 or 3 x 3)
//    texels below it in linear values, each weighted by the level-0 texels under it, so every
//    level keeps the image's mean (up to the rounding of its storage).
#pragma once

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace penumbra {

// How a texture's texels are stored and what their values mean.
enum class TexelEncoding : uint8_t {
  kSrgb8,     // 8 bits per channel, colour sRGB-encoded, alpha linear
  kLinear8,   // 8 bits per channel, values as stored (data)
  kLinear16,  // 16 bits per channel, linear (16-bit files, colour decoded to linear on loading)
};

struct TextureLevel {
  int width = 0;
  int height = 0;
  // RGBA per texel, row-major, row 0 at the top: in bytes8 (8-bit encodings) or texels16.
  std::vector<uint8_t> bytes8;
  std::vector<uint16_t> texels16;
};

class Texture {
 public:
  // A texture from RGBA texels (8 bits per channel when `texels8` is given, 16 otherwise), its
  // pyramid built here. `colour`: the colour channels are sRGB-encoded colour (decoded on
  // fetch; 16-bit values are decoded to linear here); otherwise data, read as stored.
  static Texture fromRgba8(std::string source, int width, int height, std::vector<uint8_t> texels8,
                           bool colour, int file_channels);
  static Texture fromRgba16(std::string source, int width, int height,
                            std::span<const uint16_t> texels16, bool colour, int file_channels);

  const std::string& source() const { return source_; }  // the file or embedded image, for messages
  TexelEncoding encoding() const { return encoding_; }
  int width() const { return levels_[0].width; }
  int height() const { return levels_[0].height; }
  int levelCount() const { return int(levels_.size()); }
  const TextureLevel& level(int k) const { return levels_[size_t(k)]; }
  // Channels in the file: 1 grey, 2 grey and alpha, 3 RGB, 4 RGBA (grey is expanded to RGB).
  int fileChannels() const { return file_channels_; }
  // Whether some texel's alpha is below 1.
  bool hasAlpha() const { return has_alpha_; }
  // The mean of level 0 (linear RGBA).
  glm::vec4 mean() const { return mean_; }
  size_t memoryBytes() const;
  // The bytes a w x h texture with its pyramid takes (for memory checks before decoding).
  static uint64_t plannedBytes(int width, int height, bool sixteen_bit);

  // Texel (x, y) of level k, coordinates already wrapped into the level (linear RGBA).
  glm::vec4 fetch(int k, int x, int y) const;

 private:
  Texture() = default;
  void buildPyramid();

  std::string source_;
  TexelEncoding encoding_ = TexelEncoding::kSrgb8;
  int file_channels_ = 4;
  bool has_alpha_ = false;
  glm::vec4 mean_{0.0f};
  std::vector<TextureLevel> levels_;
};

// glTF sampler wrap modes (glTF 2.0 sec. 5.26; the OpenGL ones of the same names).
enum class TextureWrap : uint8_t { kRepeat, kClampToEdge, kMirroredRepeat };

struct TextureSampler {
  TextureWrap wrap_s = TextureWrap::kRepeat;
  TextureWrap wrap_t = TextureWrap::kRepeat;
  // magFilter NEAREST: point lookups (the texel holding the point) instead of bilinear ones.
  bool nearest = false;
};

// A texture as one material slot reads it.
struct TextureBinding {
  std::shared_ptr<const Texture> texture;
  uint32_t uv_set = 0;  // TEXCOORD_n (glTF texCoord); 0 for OBJ and JSON scenes
  TextureSampler sampler;
  // The UV transform, applied to the mesh's UVs in their own convention: (u', v') =
  // (dot(row_u, (u, v, 1)), dot(row_v, (u, v, 1))). KHR_texture_transform's
  // T(offset) R(rotation) S(scale); MTL's -s (scale) and -o (offset).
  glm::vec3 row_u{1.0f, 0.0f, 0.0f};
  glm::vec3 row_v{0.0f, 1.0f, 0.0f};

  // The image coordinates (s, t) of mesh UV `uv` on a mesh whose v axis is `uv_origin_top`.
  glm::vec2 imageCoordinates(glm::vec2 uv, bool uv_origin_top) const {
    const glm::vec3 h(uv, 1.0f);
    const float u = row_u.x * h.x + row_u.y * h.y + row_u.z;
    const float v = row_v.x * h.x + row_v.y * h.y + row_v.z;
    return {u, uv_origin_top ? v : 1.0f - v};
  }
  // Sets the transform of KHR_texture_transform: uv' = T(offset) R(rotation) S(scale) uv.
  void setTransform(glm::vec2 offset, float rotation, glm::vec2 scale);
};

// The texture at image coordinates `st` on level 0 (what a ray's hit reads): bilinear, or the
// texel holding the point for a nearest sampler; wrapped by the sampler's modes.
glm::vec4 sampleTexture(const Texture& texture, const TextureSampler& sampler, glm::vec2 st);
// Bilinear on level k (the footprint means read coarser levels).
glm::vec4 sampleTextureLevel(const Texture& texture, const TextureSampler& sampler, glm::vec2 st,
                             int k);

// Trilinear: bilinear on levels floor(level) and the next, mixed by the fraction (`level` in
// [0, levelCount() - 1]).
glm::vec4 sampleTextureTrilinear(const Texture& texture, const TextureSampler& sampler,
                                 glm::vec2 st, float level);

// sRGB transfer function (IEC 61966-2-1) to linear, for one 8-bit value.
float srgb8ToLinear(uint8_t v);

}  // namespace penumbra
