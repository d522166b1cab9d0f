// Texture files as other tools write them, for the loaders' tests: 8-bit PNG and JPEG (through
// stb_image_write), 16-bit PNG (written here: stored deflate blocks), lossless WebP (libwebp),
// and a chequer pattern to fill them with.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace penumbra::test {

// RGBA texels, row 0 at the top.
struct Rgba8Image {
  int width = 0;
  int height = 0;
  std::vector<uint8_t> texels;  // 4 per texel
};

// `cells` x `cells` squares alternating `a` and `b` (RGBA), `a` in the top-left one.
Rgba8Image chequer(int width, int height, int cells, const uint8_t a[4], const uint8_t b[4]);

// The image as a file's bytes: PNG with `channels` of the texels (1 grey, 2 grey and alpha, 3 RGB,
// 4 RGBA), JPEG (RGB, quality 100), lossless WebP (RGBA).
std::string pngBytes(const Rgba8Image& image, int channels = 4);
std::string jpegBytes(const Rgba8Image& image);
std::string webpBytes(const Rgba8Image& image);
// A 16-bit RGBA PNG of `texels` (4 per texel, row 0 at the top).
std::string png16Bytes(int width, int height, const std::vector<uint16_t>& texels);

}  // namespace penumbra::test
