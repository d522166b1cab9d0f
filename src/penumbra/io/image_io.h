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
#include <vector>

namespace penumbra {

// True for .exr, .hdr, .pfm, .png (case-insensitive).
bool isSupportedImageExtension(const std::string& path);

// Writes `linear` by the extension of `path`; `tonemap` applies to .png only.
Status writeImage(const std::string& path, const Image& linear,
                  const ToneMapSettings& tonemap = {});

// The 8-bit sRGB bytes (RGB, row-major, top row first) a .png of `linear` holds.
std::vector<uint8_t> displayBytes(const Image& linear, const ToneMapSettings& tonemap = {});
// Writes 8-bit sRGB pixels as they are (a window's capture) to a .png.
Status writePng8(const std::string& path, int width, int height, std::span<const uint8_t> rgb);

// Reads .exr, .hdr, .pfm (linear) and .png (decoded from sRGB to linear).
Expected<Image> readImage(const std::string& path);

// Reads an image that holds data rather than colour (a normal map): .png values as stored,
// scaled to [0, 1], without sRGB decoding; the other formats as readImage.
Expected<Image> readImageData(const std::string& path);
// The same for PNG bytes in memory (an image embedded in a glTF file); `name` for messages.
Expected<Image> decodePngData(const std::string& name, const std::string& bytes);

}  // namespace penumbra
