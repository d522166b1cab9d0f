// Texture files as other tools write them, for the loaders' tests: 8-bit PNG and JPEG (through
// stb_image_write), 16-bit PNG (written here: stored deflate blocks), lossless WebP (libwebp),
// and a chequer pattern to fill them with; PNG of every colour type and depth (libpng), JPEG
// (libjpeg-turbo, baseline or progressive), lossy WebP, and PNGs of any size whose pixels are all
// zero, made in no time (for decode bombs).
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

// A PNG through libpng. `samples`: width x height pixels of `channels` samples each (palette: one
// index), row 0 at the top, each value within the bit depth.
struct PngSpec {
  int width = 0, height = 0;
  int colour_type = 6;  // PNG_COLOR_TYPE_*: 0 grey, 2 RGB, 3 palette, 4 grey+alpha, 6 RGBA
  int bit_depth = 8;
  bool interlaced = false;
  std::vector<uint16_t> samples;
  std::vector<uint8_t> palette;        // RGB triples (colour type 3)
  std::vector<uint8_t> palette_alpha;  // tRNS for the first entries (colour type 3)
  // Image data is checked by libpng's writer against the palette; `unchecked_indices` writes
  // indices past it all the same.
  bool unchecked_indices = false;
};
std::string encodePng(const PngSpec& spec);

// A JPEG through libjpeg-turbo: RGB (or grey: the red channel) at `quality`, progressive
// (jpeg_simple_progression) when asked.
std::string encodeJpeg(const Rgba8Image& image, int quality = 95, bool progressive = false,
                       bool grey = false);

// A lossy WebP (libwebp) of the RGBA image, alpha kept when some texel has it.
std::string webpLossyBytes(const Rgba8Image& image, float quality = 90.0f);

// A PNG whose every sample is 0, of any size: the image data is one deflate block for 1 MiB of
// zeros repeated (each ends byte-aligned, and with a window of zeros each encodes the same), so a
// 16384 x 16384 16-bit RGBA image (2 GiB decoded) is about 2 MB made in milliseconds.
std::string zeroPng(int width, int height, int colour_type, int bit_depth);

}  // namespace penumbra::test
