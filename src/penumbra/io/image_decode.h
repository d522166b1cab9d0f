// Texture images: PNG (libpng), JPEG (libjpeg-turbo), WebP (libwebp), BMP (Penumbra's own reader)
// and TGA (stb_image, after Penumbra's own checks of its header and pixel data), read from bytes
// that may be hostile.
//
// Every image goes through the same three steps, so a scene can refuse what will not fit before
// it decodes anything (DESIGN.md sec. 5): readImageHeader reads and checks the header (sizes
// against what the format can store and what the file's bytes can hold, by the real bit depth
// and palette); planImage says what decoding will take (pure arithmetic on the header); decode
// checks that memory and decodes.
//
// Size limit. An image wider or taller than ImageLimits::max_size is reduced, not refused: by the
// smallest power of two that brings both sides within the limit, each texel the mean of the
// stored (sRGB-encoded) values it covers, as JPEG's DCT scaling and libwebp's scaler give them (a
// mip level averages in linear light instead: on detail finer than the reduction, a black and
// white checker gives code 128, 0.22 linear, not 0.5). A scene's textures are averaged over surface
// elements and filtered by a mip pyramid, so detail finer than 1/8192 of a texture is not seen;
// refusing would make valid assets (16K photo-scanned textures) unusable. The reduction never
// holds the full image where the decoder allows it: JPEG decodes at 1/2, 1/4 or 1/8 scale in the
// DCT (libjpeg-turbo), WebP through libwebp's scaler, PNG and BMP row by row into a running box
// filter. TGA (stb) is decoded whole first; its file holds the pixels raw or run-length encoded
// (at most 128:1), so the file bounds that. The caller warns (TextureTexels::warnings).
//
// Budgets (ImageLimits): a JPEG may have at most `max_scans` scans (a progressive JPEG has about
// 10; each scan walks the whole image, so 150,000 empty scans take minutes), and one image's
// decoding may take at most `max_seconds`.
//
// Values: colour texels are returned as stored (sRGB-encoded; scene/texture.h decodes them),
// data images (normal maps) scaled to [0, 1]. Gamma, ICC and colour-space chunks are ignored:
// textures are sRGB (glTF 2.0 sec. 3.8.4). Palette indices past the palette read as opaque black
// (libpng's rule: its palette is 256 zeroed entries) in PNG and BMP, and as the first entry in
// TGA (stb's rule), with a warning: what a browser shows, identical on every run. A PNG chunk whose
// CRC fails is an error when it holds pixels (IHDR, PLTE, tRNS, IDAT: the file is damaged and its
// colours cannot be trusted) and a warning otherwise (text, ICC: the pixels are intact). Every
// error is one line naming the image, in plain words.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra {

enum class ImageFormat : uint8_t { kPng, kJpeg, kWebp, kBmp, kTga, kKtx2, kUnknown };
// "PNG", "JPEG", "WebP", "BMP", "TGA", "KTX2", "unknown".
const char* imageFormatName(ImageFormat f);
// The format of an image's bytes by signature (TGA, which has none, by a ".tga" name; KTX2 by its
// 12-byte identifier).
ImageFormat imageFormatOf(const std::string& name, std::string_view bytes);

// What an image's header says, read without decoding pixels.
struct ImageHeader {
  ImageFormat format = ImageFormat::kUnknown;
  int width = 0, height = 0;
  int channels =
      0;         // as decoded: 1 grey, 2 grey+alpha, 3 RGB, 4 RGBA (a palette expands to 3 or 4)
  int bits = 8;  // per stored sample: 1, 2, 4, 8, 16 (PNG), 8 (JPEG); BMP/TGA: per pixel
  bool palette = false;
  bool sixteen_bit = false;  // decoded at 16 bits per channel (16-bit PNG)
  bool interlaced = false;   // PNG Adam7: a reduced one sums the whole reduced image at once
  int scans = 1;             // JPEG: the start-of-scan markers the file holds (others: 1)
  // Bytes the format's decoder holds for the whole image at full size, whatever size it is decoded
  // at: a progressive or multi-scan JPEG's DCT coefficients, a lossless WebP's ARGB pixels, a
  // WebP's alpha plane, stb's whole TGA. 0 where the decoder streams rows.
  uint64_t full_size_buffer_bytes = 0;
};
// Reads and checks the header. An input error naming `name` when the bytes are not an image of a
// format above, the format is one Penumbra does not decode (12-bit, lossless or CMYK JPEG, RLE
// BMP, KTX2, animated WebP), a size exceeds what the format can store, or the file cannot hold the
// pixels its header claims (truncated, or a PNG with less image data than deflate needs).
Expected<ImageHeader> readImageHeader(const std::string& name, std::string_view bytes);

// Limits applied when decoding (defaults for the command line's --max-texture-size).
struct ImageLimits {
  int max_size = 8192;      // the largest width or height a texture keeps (at least 1)
  int max_scans = 500;      // JPEG scans (libjpeg-turbo's own TJFLAG_LIMITSCANS allows 500)
  double max_seconds = 60;  // wall time for decoding one image (a backstop; decoders check it
                            // per row or per scan; BMP, TGA and WebP run to the end)
};

// What a texture will take: its size after any reduction to `limits.max_size`, the bytes it holds
// with its mip pyramid (Texture::plannedBytes), and the peak while decoding it (decoder buffers,
// the decoded texels and the texture built from them, all at once: an upper bound). Pure
// arithmetic on the header: callers sum plans over every image of a scene before decoding any
// (plannedSceneBytes).
struct ImagePlan {
  int width = 0, height = 0;
  bool reduced = false;
  uint64_t texture_bytes = 0, peak_bytes = 0;
};
ImagePlan planImage(const ImageHeader& header, const ImageLimits& limits);
// The same for a data image (decodeDataImage): texture_bytes is the Image's (12 bytes a pixel).
ImagePlan planDataImage(const ImageHeader& header, const ImageLimits& limits);
// What decoding every image of a scene one after another takes at most: every texture's bytes
// and the largest transient (peak_bytes - texture_bytes) of any one.
uint64_t plannedSceneBytes(std::span<const ImagePlan> plans);

// A texture image's texels: RGBA, 8 or 16 bits per channel (16 for 16-bit PNGs only), grey
// expanded to RGB and a missing alpha set to the maximum, top row first.
struct TextureTexels {
  int width = 0;
  int height = 0;
  int channels = 0;  // in the file: 1 grey, 2 grey and alpha, 3 RGB, 4 RGBA
  bool sixteen_bit = false;
  std::vector<uint8_t> rgba8;
  std::vector<uint16_t> rgba16;
  // The image's size in its file: larger than width x height when it was reduced to the limit.
  int file_width = 0;
  int file_height = 0;
  bool reduced() const { return width != file_width || height != file_height; }
  // What the caller should pass on as warnings, each a phrase that does not name the image:
  // "reduced from 16384 x 16384 to 8192 x 8192 (...)", a bad CRC in a chunk that is not used,
  // palette indices past the palette, libjpeg's notes on damaged data it decoded.
  std::vector<std::string> warnings;
};
// Decodes a PNG (1 to 16 bits, palette, grey, interlaced), JPEG (8-bit, baseline, progressive or
// arithmetic), WebP (lossy, lossless, alpha), BMP (1, 4, 8, 16, 24, 32 bits, bottom-up or
// top-down, uncompressed or bit fields) or TGA (colour-mapped, true colour, grey, RLE) image;
// `name` for messages. Memory is checked (core/memory.h) against planImage before allocating.
Expected<TextureTexels> decodeTextureImage(const std::string& name, std::string_view bytes,
                                           const ImageLimits& limits = {});

// A data image (normal map): any format above, values as stored scaled to [0, 1] (alpha dropped),
// no sRGB decoding. The second form appends what the caller should warn about to `warnings`.
Expected<Image> decodeDataImage(const std::string& name, std::string_view bytes,
                                const ImageLimits& limits = {});
Expected<Image> decodeDataImage(const std::string& name, std::string_view bytes,
                                const ImageLimits& limits, std::vector<std::string>* warnings);

}  // namespace penumbra
