// Image files. Linear radiance goes to .exr (OpenEXR, 32-bit float RGB), .hdr (Radiance RGBE)
// and .pfm (Portable Float Map); .png is tone-mapped 8-bit sRGB. Every write is atomic: a
// temporary file renamed into place, never a partial file.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/io/tonemap.h"

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra {

// True for .exr, .hdr, .pfm, .png (case-insensitive).
bool isSupportedImageExtension(const std::string& path);

// Writes `linear` by the extension of `path`; `tonemap` applies to .png only.
Status writeImage(const std::string& path, const Image& linear,
                  const ToneMapSettings& tonemap = {});

// The 8-bit sRGB bytes (RGB, row-major, top row first) a .png of `linear` holds.
std::vector<uint8_t> displayBytes(const Image& linear, const ToneMapSettings& tonemap = {});
// Writes 8-bit pixels as they are (RGB, or RGBA with channels 4; a window's capture) to a .png.
Status writePng8(const std::string& path, int width, int height, std::span<const uint8_t> rgb,
                 int channels = 3);

// Reads .exr, .hdr, .pfm (linear) and .png (decoded from sRGB to linear).
Expected<Image> readImage(const std::string& path);

// Reads an image that holds data rather than colour (a normal map): .png values as stored,
// scaled to [0, 1], without sRGB decoding; the other formats as readImage.
Expected<Image> readImageData(const std::string& path);
// The same for PNG bytes in memory (an image embedded in a glTF file); `name` for messages.
Expected<Image> decodePngData(const std::string& name, const std::string& bytes);

// A texture image's texels as its file holds them: RGBA, 8 or 16 bits per channel (16 for 16-bit
// PNGs only), grey expanded to RGB and a missing alpha set to the maximum, top row first.
struct TextureTexels {
  int width = 0;
  int height = 0;
  int channels = 0;  // in the file: 1 grey, 2 grey and alpha, 3 RGB, 4 RGBA
  bool sixteen_bit = false;
  std::vector<uint8_t> rgba8;
  std::vector<uint16_t> rgba16;
};
// Decodes a PNG (8 or 16 bits), JPEG, WebP (libwebp), BMP or TGA image, recognised by its
// signature (TGA, which has none, by a ".tga" name); `name` for messages. Sizes are checked
// against the file and the memory available before decoding.
Expected<TextureTexels> decodeTextureImage(const std::string& name, std::string_view bytes);
Expected<TextureTexels> readTextureImage(const std::string& path);

}  // namespace penumbra
