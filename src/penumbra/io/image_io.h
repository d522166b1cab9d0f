// Image files. Linear radiance goes to .exr (OpenEXR, 32-bit float RGB), .hdr (Radiance RGBE)
// and .pfm (Portable Float Map); .png is tone-mapped 8-bit sRGB. Every write is atomic: a
// temporary file renamed into place, never a partial file.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/render/tonemap.h"

#include <string>

namespace penumbra {

// True for .exr, .hdr, .pfm, .png (case-insensitive).
bool isSupportedImageExtension(const std::string& path);

// Writes `linear` by the extension of `path`; `tonemap` applies to .png only.
Status writeImage(const std::string& path, const Image& linear,
                  const ToneMapSettings& tonemap = {});

// Reads .exr, .hdr, .pfm (linear) and .png (decoded from sRGB to linear).
Expected<Image> readImage(const std::string& path);

}  // namespace penumbra
