// Image files. Linear radiance goes to .exr (OpenEXR, 32-bit float RGB), .hdr (Radiance RGBE)
// and .pfm (Portable Float Map); .png is tone-mapped 8-bit sRGB. Every write is atomic: a
// temporary file renamed into place, never a partial file.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/io/image_decode.h"
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
// 8-bit pixels as they are (RGB, or RGBA with channels 4) as the bytes of a PNG file.
Expected<std::string> encodePng8(int width, int height, std::span<const uint8_t> pixels,
                                 int channels);
// Writes 8-bit pixels as they are (RGB, or RGBA with channels 4; a window's capture) to a .png.
Status writePng8(const std::string& path, int width, int height, std::span<const uint8_t> rgb,
                 int channels = 3);

// Reads .exr, .hdr, .pfm (linear) and .png (libpng through image_decode.h, never reduced,
// decoded from sRGB to linear).
Expected<Image> readImage(const std::string& path);

// Reads an image that holds data rather than colour (a normal map): PNG, JPEG, WebP, BMP or TGA
// through decodeDataImage (image_decode.h: values as stored, scaled to [0, 1], no sRGB decoding;
// reduced to `limits`, with a warning appended to `warnings`), the other formats as readImage.
Expected<Image> readImageData(const std::string& path);
Expected<Image> readImageData(const std::string& path, const ImageLimits& limits,
                              std::vector<std::string>* warnings);

}  // namespace penumbra
