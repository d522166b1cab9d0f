// Texture images (image_decode.h). Each format has a header reader, which checks everything a
// decoder would otherwise trust (sizes, offsets, the bytes the pixels need), and a decoder, which
// hands rows of RGBA to a BoxReducer that writes the output at its final size.
//
//   PNG   libpng 1.6, read row by row (Adam7 passes as they come), CRCs checked.
//   JPEG  libjpeg-turbo, scaled in the DCT (1/2, 1/4, 1/8), a progress monitor counting scans.
//   WebP  libwebp, scaled by libwebp's rescaler.
//   BMP   Penumbra's own reader: uncompressed rows, palette, 16/32-bit bit fields. stb_image's
//         reads an uninitialised palette for indices past it and refuses pixel data that does
//         not follow the header at once; this one streams rows and reduces as it goes.
//   TGA   stb_image, after the header and every RLE packet are checked against the file.
//
// libpng and libjpeg report errors by longjmp: the functions that call setjmp (pngRun,
// jpegRun) and everything between them and the libraries hold only plain data, so no destructor
// is skipped ([csetjmp.syn]); buffers are made before and released after.
#include "penumbra/io/image_decode.h"

#include "penumbra/core/check.h"
#include "penumbra/core/file_util.h"
#include "penumbra/core/memory.h"
#include "penumbra/scene/texture.h"

#include <fmt/format.h>

#include <climits>
#include <csetjmp>
#include <cstdio>
// jpeglib.h needs FILE and size_t declared first.
#include <jpeglib.h>
// After jpeglib.h, whose configuration says which messages jerror.h names.
#include <jerror.h>
#include <png.h>
#include <webp/decode.h>
#include <zlib.h>

// stb_image for TGA only, private to this file (image_io.cpp has its own copy for Radiance HDR).
#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_TGA
#define STBI_NO_STDIO
#define STBI_NO_LINEAR
#include <stb_image.h>

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cstring>
#include <limits>
#include <memory>
#include <new>
#include <string>
#include <utility>

namespace penumbra {

namespace {

constexpr std::string_view kPngSignature("\x89PNG\r\n\x1a\n", 8);
constexpr std::string_view kKtx2Identifier("\xabKTX 20\xbb\r\n\x1a\n", 12);

Error imageError(const std::string& name, std::string message) {
  return inputError(name, "", std::move(message));
}

uint8_t byteAt(std::string_view b, size_t at) {
  return uint8_t(b[at]);
}
uint32_t be16(std::string_view b, size_t at) {
  return uint32_t(byteAt(b, at)) << 8 | byteAt(b, at + 1);
}
uint32_t be32(std::string_view b, size_t at) {
  return be16(b, at) << 16 | be16(b, at + 2);
}
uint32_t le16(std::string_view b, size_t at) {
  return uint32_t(byteAt(b, at + 1)) << 8 | byteAt(b, at);
}
uint32_t le32(std::string_view b, size_t at) {
  return le16(b, at + 2) << 16 | le16(b, at);
}

uint64_t ceilDiv(uint64_t a, uint64_t b) {
  return (a + b - 1) / b;
}

// The power of two an image is reduced by: the smallest that brings both sides within max_size.
uint64_t reductionFactor(uint64_t width, uint64_t height, int max_size) {
  PENUMBRA_CHECK_MSG(max_size >= 1, "ImageLimits::max_size {} must be at least 1", max_size);
  uint64_t f = 1;
  while (ceilDiv(width, f) > uint64_t(max_size) || ceilDiv(height, f) > uint64_t(max_size)) f *= 2;
  return f;
}

// Wall time left for one image's decoding.
class Deadline {
 public:
  explicit Deadline(double seconds)
      : unlimited_(!(seconds < 1e9)),
        end_(std::chrono::steady_clock::now() +
             std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                 std::chrono::duration<double>(unlimited_ ? 0.0 : std::max(seconds, 0.0)))) {}
  bool passed() const { return !unlimited_ && std::chrono::steady_clock::now() > end_; }

 private:
  bool unlimited_;
  std::chrono::steady_clock::time_point end_;
};

std::string timeMessage(double seconds) {
  return fmt::format("decoding it took longer than {:g} s, the limit for one image", seconds);
}

// ---- output --------------------------------------------------------------------------------

// Where decoded pixels go, at the output size: a texture's RGBA texels (8 or 16 bits, as the
// samples come) or a data image's floats (values over 255 or 65535).
class TexelOutput {
 public:
  TexelOutput(int width, int height, TextureTexels* texels, Image* image)
      : width_(width), height_(height), texels_(texels), image_(image) {}
  int width() const { return width_; }
  int height() const { return height_; }

  template <typename T>
  void row(int y, const T* rgba) {
    const size_t first = size_t(y) * size_t(width_);
    if (!image_) {
      std::memcpy(texelsOf<T>() + 4 * first, rgba, 4 * size_t(width_) * sizeof(T));
      return;
    }
    for (size_t x = 0; x < size_t(width_); ++x) pixel(first + x, rgba + 4 * x);
  }
  template <typename T>
  void pixel(int x, int y, const T* rgba) {
    pixel(size_t(y) * size_t(width_) + size_t(x), rgba);
  }

 private:
  template <typename T>
  T* texelsOf() {
    if constexpr (sizeof(T) == 2) {
      return texels_->rgba16.data();
    } else {
      return texels_->rgba8.data();
    }
  }
  template <typename T>
  void pixel(size_t i, const T* rgba) {
    if (image_) {
      constexpr double kScale = 1.0 / double(std::numeric_limits<T>::max());
      image_->pixels[i] =
          glm::vec3(float(rgba[0] * kScale), float(rgba[1] * kScale), float(rgba[2] * kScale));
    } else {
      std::memcpy(texelsOf<T>() + 4 * i, rgba, 4 * sizeof(T));
    }
  }

  int width_, height_;
  TextureTexels* texels_;
  Image* image_;
};

// A pixel of 1 (grey), 2 (grey, alpha), 3 (RGB) or 4 (RGBA) samples as RGBA.
template <typename T>
void toRgba(const T* in, int channels, T* out) {
  constexpr T kOpaque = std::numeric_limits<T>::max();
  switch (channels) {
    case 1:
      out[0] = out[1] = out[2] = in[0], out[3] = kOpaque;
      break;
    case 2:
      out[0] = out[1] = out[2] = in[0], out[3] = in[1];
      break;
    case 3:
      out[0] = in[0], out[1] = in[1], out[2] = in[2], out[3] = kOpaque;
      break;
    default:
      out[0] = in[0], out[1] = in[1], out[2] = in[2], out[3] = in[3];
      break;
  }
}

// Rows of `channels` samples a pixel in, top first, reduced by `factor` (a box filter: each
// output texel the rounded mean of the up to factor x factor texels it covers; the last row and
// column cover what is left) and written to the output as RGBA. The sums are kept per decoded
// channel, so a grey image costs a quarter of an RGBA one.
template <typename T>
class BoxReducer {
 public:
  BoxReducer(int in_width, int in_height, uint64_t factor, int channels, TexelOutput& out)
      : in_width_(uint64_t(in_width)),
        in_height_(uint64_t(in_height)),
        factor_(factor),
        channels_(channels),
        out_(out),
        rgba_(4 * size_t(out.width())) {
    if (factor_ > 1) {
      sums_.assign(4 * size_t(out.width()), 0);
      means_.resize(4);
    }
  }
  // Fewer channels than the reducer was made for (libpng says how many after its transforms).
  void setChannels(int channels) { channels_ = std::min(channels, 4); }
  void add(const T* row) {
    if (factor_ == 1) {
      emitRow(row);
    } else {
      switch (channels_) {
        case 1:
          sum<1>(row);
          break;
        case 2:
          sum<2>(row);
          break;
        case 3:
          sum<3>(row);
          break;
        default:
          sum<4>(row);
          break;
      }
    }
    ++rows_in_;
    if (factor_ > 1 && (rows_in_ % factor_ == 0 || rows_in_ == in_height_)) emitMeans();
  }

 private:
  template <int N>
  void sum(const T* row) {
    for (uint64_t ox = 0, x = 0; ox < uint64_t(out_.width()); ++ox) {
      uint64_t* s = &sums_[N * ox];
      for (const uint64_t end = std::min(x + factor_, in_width_); x < end; ++x) {
        for (int c = 0; c < N; ++c) s[c] += row[N * x + uint64_t(c)];
      }
    }
  }
  void emitRow(const T* row) {
    if (channels_ == 4) {
      out_.row(int(out_y_++), row);
      return;
    }
    for (size_t x = 0; x < size_t(out_.width()); ++x) {
      toRgba(row + size_t(channels_) * x, channels_, &rgba_[4 * x]);
    }
    out_.row(int(out_y_++), rgba_.data());
  }
  void emitMeans() {
    const uint64_t rows = rows_in_ - out_y_ * factor_;
    const uint64_t n = uint64_t(channels_);
    for (uint64_t ox = 0; ox < uint64_t(out_.width()); ++ox) {
      const uint64_t count = rows * std::min(factor_, in_width_ - ox * factor_);
      for (uint64_t c = 0; c < n; ++c) {
        means_[c] = T((sums_[n * ox + c] + count / 2) / count);
        sums_[n * ox + c] = 0;
      }
      toRgba(means_.data(), channels_, &rgba_[4 * ox]);
    }
    out_.row(int(out_y_++), rgba_.data());
  }

  uint64_t in_width_, in_height_, factor_;
  int channels_;
  TexelOutput& out_;
  std::vector<uint64_t> sums_;
  std::vector<T> means_, rgba_;
  uint64_t rows_in_ = 0, out_y_ = 0;
};

// Pixels in any order (an interlaced PNG's passes), reduced as BoxReducer does. Without a
// reduction they go straight to the output; with one, 32-bit sums of the whole reduced image are
// kept (a reduced interlaced PNG is at most 256 times the limit a side, so 65535 x 256^2 fits).
template <typename T>
class PixelSums {
 public:
  PixelSums(int in_width, int in_height, uint64_t factor, int channels, TexelOutput& out)
      : in_width_(uint64_t(in_width)),
        in_height_(uint64_t(in_height)),
        factor_(factor),
        channels_(channels),
        out_(out) {
    if (factor_ > 1) {
      sums_.assign(size_t(channels) * size_t(out.width()) * size_t(out.height()), 0);
    }
  }
  void setChannels(int channels) { channels_ = std::min(channels, channels_); }
  void add(uint64_t x, uint64_t y, const T* pixel) {
    if (factor_ == 1) {
      T rgba[4];
      toRgba(pixel, channels_, rgba);
      out_.pixel(int(x), int(y), rgba);
      return;
    }
    const uint64_t n = uint64_t(channels_);
    uint32_t* s = &sums_[n * ((y / factor_) * uint64_t(out_.width()) + x / factor_)];
    for (uint64_t c = 0; c < n; ++c) s[c] += pixel[c];
  }
  void finish() {
    if (factor_ == 1) return;
    const uint64_t n = uint64_t(channels_);
    std::vector<T> row(4 * size_t(out_.width()));
    T means[4] = {};
    for (uint64_t oy = 0; oy < uint64_t(out_.height()); ++oy) {
      const uint64_t rows = std::min(factor_, in_height_ - oy * factor_);
      for (uint64_t ox = 0; ox < uint64_t(out_.width()); ++ox) {
        const uint64_t count = rows * std::min(factor_, in_width_ - ox * factor_);
        const uint32_t* s = &sums_[n * (oy * uint64_t(out_.width()) + ox)];
        for (uint64_t c = 0; c < n; ++c) means[c] = T((s[c] + count / 2) / count);
        toRgba(means, channels_, &row[4 * ox]);
      }
      out_.row(int(oy), row.data());
    }
  }

 private:
  uint64_t in_width_, in_height_, factor_;
  int channels_;
  TexelOutput& out_;
  std::vector<uint32_t> sums_;
};

// One image's decoding: what every decoder needs.
struct DecodeJob {
  const std::string& name;
  std::string_view bytes;
  const ImageHeader& header;
  const ImageLimits& limits;
  uint64_t factor = 1;
  TexelOutput& out;
  std::vector<std::string>& warnings;
  Deadline deadline;
  int channels = 0;  // as decoded (the header's, unless decoding finds otherwise)
};

}  // namespace

// ---- formats ---------------------------------------------------------------------------------

const char* imageFormatName(ImageFormat f) {
  switch (f) {
    case ImageFormat::kPng:
      return "PNG";
    case ImageFormat::kJpeg:
      return "JPEG";
    case ImageFormat::kWebp:
      return "WebP";
    case ImageFormat::kBmp:
      return "BMP";
    case ImageFormat::kTga:
      return "TGA";
    case ImageFormat::kKtx2:
      return "KTX2";
    case ImageFormat::kUnknown:
      break;
  }
  return "unknown";
}

ImageFormat imageFormatOf(const std::string& name, std::string_view bytes) {
  if (bytes.substr(0, 8) == kPngSignature) return ImageFormat::kPng;
  if (bytes.substr(0, 3) == std::string_view("\xff\xd8\xff", 3)) return ImageFormat::kJpeg;
  if (bytes.size() >= 12 && bytes.substr(0, 4) == "RIFF" && bytes.substr(8, 4) == "WEBP") {
    return ImageFormat::kWebp;
  }
  if (bytes.substr(0, 12) == kKtx2Identifier) return ImageFormat::kKtx2;
  if (bytes.substr(0, 2) == "BM") return ImageFormat::kBmp;
  if (extensionOf(name) == ".tga") return ImageFormat::kTga;
  return ImageFormat::kUnknown;
}

namespace {

// What an unknown file is, when its signature says so, for the message.
std::string unknownFormatMessage(std::string_view b) {
  struct Known {
    std::string_view signature;
    size_t at;
    const char* what;
  };
  static const Known kKnown[] = {
      {"GIF8", 0, "a GIF image"},
      {std::string_view("II*\0", 4), 0, "a TIFF image"},
      {std::string_view("MM\0*", 4), 0, "a TIFF image"},
      {"\x76\x2f\x31\x01", 0, "an OpenEXR image"},
      {"#?RADIANCE", 0, "a Radiance HDR image"},
      {"#?RGBE", 0, "a Radiance HDR image"},
      {"8BPS", 0, "a Photoshop document"},
      {"DDS ", 0, "a DDS texture"},
      {"\xabKTX 11", 0, "a KTX 1 texture"},
      {"ftyp", 4, "an HEIF or AVIF image"},
      {"glTF", 0, "a glTF binary file"},
  };
  for (const Known& k : kKnown) {
    if (b.size() >= k.at + k.signature.size() &&
        b.substr(k.at, k.signature.size()) == k.signature) {
      return fmt::format("{} is not read as a texture (use PNG, JPEG, WebP, BMP or TGA)", k.what);
    }
  }
  return "not a PNG, JPEG, WebP, BMP or TGA image (no signature of any of them; a TGA is "
         "recognised by its .tga name)";
}

// ---- PNG header ------------------------------------------------------------------------------

// The chunks of a PNG as far as decoding depends on them. Chunk layout (PNG spec, 5.3): a 4-byte
// length, a 4-byte type, the data, a CRC-32 of type and data.
struct PngLayout {
  uint32_t width = 0, height = 0;
  int depth = 0, colour_type = 0;
  bool interlaced = false;
  int palette_entries = 0;
  bool transparency = false;  // a tRNS chunk libpng will use
  uint64_t idat_bytes = 0;
};

int pngSamples(int colour_type) {
  switch (colour_type) {
    case 0:
      return 1;  // grey
    case 2:
      return 3;  // RGB
    case 3:
      return 1;  // palette index
    case 4:
      return 2;  // grey and alpha
    case 6:
      return 4;  // RGBA
    default:
      return 0;
  }
}

const char* pngColourName(int colour_type) {
  switch (colour_type) {
    case 0:
      return "grey";
    case 2:
      return "RGB";
    case 3:
      return "palette";
    case 4:
      return "grey and alpha";
    default:
      return "RGBA";
  }
}

// The bytes of filtered scan lines the image data must inflate to (PNG spec, 7.2 and 8.2).
uint64_t pngRawBytes(const PngLayout& p) {
  const uint64_t bits = uint64_t(p.depth) * uint64_t(pngSamples(p.colour_type));
  auto rows = [&](uint64_t count, uint64_t cols) { return count * (1 + (cols * bits + 7) / 8); };
  if (!p.interlaced) return rows(p.height, p.width);
  uint64_t total = 0;
  for (int pass = 0; pass < 7; ++pass) {
    const uint64_t cols = PNG_PASS_COLS(uint64_t(p.width), pass);
    const uint64_t count = PNG_PASS_ROWS(uint64_t(p.height), pass);
    if (cols > 0 && count > 0) total += rows(count, cols);
  }
  return total;
}

Status readPngIhdr(const std::string& name, std::string_view data, PngLayout& p) {
  if (data.size() != 13) {
    return imageError(name, fmt::format("its IHDR chunk has {} bytes, not 13", data.size()));
  }
  p.width = be32(data, 0);
  p.height = be32(data, 4);
  p.depth = byteAt(data, 8);
  p.colour_type = byteAt(data, 9);
  if (p.width == 0 || p.height == 0 || p.width > 0x7fffffffu || p.height > 0x7fffffffu) {
    return imageError(name, fmt::format("a PNG of {} x {} pixels is not valid (PNG allows 1 to "
                                        "2147483647 a side)",
                                        p.width, p.height));
  }
  const int t = p.colour_type, d = p.depth;
  const bool depth_ok = t == 0   ? (d == 1 || d == 2 || d == 4 || d == 8 || d == 16)
                        : t == 3 ? (d == 1 || d == 2 || d == 4 || d == 8)
                                 : ((t == 2 || t == 4 || t == 6) && (d == 8 || d == 16));
  if (pngSamples(t) == 0) return imageError(name, fmt::format("unknown PNG colour type {}", t));
  if (!depth_ok) {
    return imageError(name, fmt::format("a {}-bit {} PNG is not valid", d, pngColourName(t)));
  }
  if (byteAt(data, 10) != 0 || byteAt(data, 11) != 0 || byteAt(data, 12) > 1) {
    return imageError(name,
                      "its IHDR chunk names an unknown compression, filter or interlace "
                      "method");
  }
  p.interlaced = byteAt(data, 12) == 1;
  return {};
}

// The chunks libpng reads before the image data, checked here so a damaged header is an error
// naming the chunk: their CRCs, and what tRNS means for the channels.
Status readPngChunk(const std::string& name, std::string_view type, std::string_view data,
                    PngLayout& p) {
  if (type == "PLTE") {
    if (data.empty() || data.size() % 3 != 0 || data.size() > 768) {
      return imageError(name, fmt::format("its palette (PLTE) has {} bytes: not 1 to 256 colours "
                                          "of 3 bytes",
                                          data.size()));
    }
    p.palette_entries = int(data.size() / 3);
  } else if (type == "tRNS" && p.idat_bytes == 0) {
    // As libpng takes it (png_handle_tRNS): otherwise ignored.
    p.transparency = (p.colour_type == 0 && data.size() == 2) ||
                     (p.colour_type == 2 && data.size() == 6) ||
                     (p.colour_type == 3 && p.palette_entries > 0 && !data.empty() &&
                      data.size() <= size_t(p.palette_entries));
  }
  return {};
}

Expected<PngLayout> readPngLayout(const std::string& name, std::string_view b) {
  PngLayout p;
  size_t pos = 8;
  for (int index = 0;; ++index) {
    if (b.size() - pos < 12) {
      return imageError(name, pos == b.size()
                                  ? "the file is truncated: it ends before its IEND chunk"
                                  : fmt::format("the file is truncated: a chunk header at byte {} "
                                                "needs 12 bytes, {} remain",
                                                pos, b.size() - pos));
    }
    const uint32_t length = be32(b, pos);
    const std::string_view type = b.substr(pos + 4, 4);
    if (!std::all_of(type.begin(), type.end(),
                     [](char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z'); })) {
      return imageError(name,
                        fmt::format("the file is damaged: no chunk type at byte {}", pos + 4));
    }
    if (length > 0x7fffffffu || length > b.size() - pos - 12) {
      return imageError(name, fmt::format("the file is truncated: chunk {} at byte {} claims {} "
                                          "bytes, {} remain",
                                          type, pos, length, b.size() - pos - 12));
    }
    const std::string_view data = b.substr(pos + 8, length);
    if (index == 0 && type != "IHDR") {
      return imageError(name, fmt::format("its first chunk is {}, not IHDR", type));
    }
    if (type == "IHDR" || type == "PLTE" || type == "tRNS") {
      const uint32_t crc =
          uint32_t(crc32(0, reinterpret_cast<const Bytef*>(b.data() + pos + 4), uInt(length + 4)));
      if (crc != be32(b, pos + 8 + length)) {
        return imageError(name,
                          fmt::format("the file is damaged: chunk {} fails its CRC check", type));
      }
    }
    if (type == "IHDR") {
      if (index != 0) return imageError(name, "it has a second IHDR chunk");
      PENUMBRA_TRY(readPngIhdr(name, data, p));
    } else if (type == "IDAT") {
      p.idat_bytes += length;
    } else if (type == "IEND") {
      break;
    } else {
      PENUMBRA_TRY(readPngChunk(name, type, data, p));
    }
    pos += 12 + size_t(length);
  }
  return p;
}

Expected<ImageHeader> readPngHeader(const std::string& name, std::string_view b) {
  Expected<PngLayout> layout = readPngLayout(name, b);
  if (!layout) return layout.error();
  const PngLayout& p = *layout;
  if (p.colour_type == 3 && p.palette_entries == 0) {
    return imageError(name, "a palette PNG without a palette (no PLTE chunk)");
  }
  if (p.idat_bytes == 0) return imageError(name, "it holds no image data (no IDAT chunk)");
  // Deflate packs at most 258 bytes into 2 bits (a length and a distance code of one bit each),
  // so image data that would inflate more than 1032 times is cut short or corrupt. This is the
  // format's real bound, by the real bit depth: a one-colour 1-bit image may be 8000:1 of its
  // decoded RGBA, and passes.
  const uint64_t raw = pngRawBytes(p);
  if (p.idat_bytes * 1032 < raw) {
    return imageError(
        name, fmt::format("its header claims {} x {} pixels ({}-bit {}), more than "
                          "its {} bytes of image data can hold (deflate expands at "
                          "most 1032 times)",
                          p.width, p.height, p.depth, pngColourName(p.colour_type), p.idat_bytes));
  }
  ImageHeader h;
  h.format = ImageFormat::kPng;
  h.width = int(p.width);
  h.height = int(p.height);
  const bool grey = p.colour_type == 0 || p.colour_type == 4;
  const bool alpha = p.colour_type == 4 || p.colour_type == 6 || p.transparency;
  h.channels = (grey ? 1 : 3) + (alpha ? 1 : 0);
  h.bits = p.depth;
  h.palette = p.colour_type == 3;
  h.sixteen_bit = p.depth == 16;
  h.interlaced = p.interlaced;
  return h;
}

// ---- JPEG header -----------------------------------------------------------------------------

// A frame header (SOFn, ITU T.81 B.2.2) and the first scan header: what libjpeg will need.
struct JpegLayout {
  int width = 0, height = 0, components = 0;
  bool progressive = false, multi_scan = false;
  uint64_t coefficient_bytes = 0;  // libjpeg's whole-image coefficient buffer, if it needs one
};

Status readJpegFrame(const std::string& name, int marker, std::string_view seg, JpegLayout& j) {
  if (marker == 0xc3 || marker == 0xc7 || marker == 0xcb || marker == 0xcf) {
    return imageError(name, "a lossless JPEG is not supported");
  }
  if (marker == 0xc5 || marker == 0xc6 || marker == 0xcd || marker == 0xce) {
    return imageError(name, "a hierarchical JPEG is not supported");
  }
  if (j.components > 0) return imageError(name, "the JPEG has two frame headers");
  if (seg.size() < 6 || seg.size() < 6 + 3 * size_t(byteAt(seg, 5))) {
    return imageError(name, "the JPEG's frame header is cut short");
  }
  const int precision = byteAt(seg, 0);
  j.height = int(be16(seg, 1));
  j.width = int(be16(seg, 3));
  j.components = byteAt(seg, 5);
  j.progressive = marker == 0xc2 || marker == 0xca;
  if (precision == 12) return imageError(name, "a 12-bit JPEG is not supported (only 8-bit ones)");
  if (precision != 8) return imageError(name, fmt::format("a {}-bit JPEG is not valid", precision));
  if (j.height == 0) {
    return imageError(name,
                      "a JPEG that gives its height after the first scan (a DNL marker) is "
                      "not supported");
  }
  if (j.width == 0) return imageError(name, "the JPEG's frame header gives a width of 0");
  if (j.width > JPEG_MAX_DIMENSION || j.height > JPEG_MAX_DIMENSION) {
    return imageError(name, fmt::format("a JPEG of {} x {} pixels is larger than libjpeg decodes "
                                        "({} a side)",
                                        j.width, j.height, JPEG_MAX_DIMENSION));
  }
  if (j.components == 4) {
    return imageError(name, "a CMYK JPEG is not supported: save it as RGB");
  }
  if (j.components != 1 && j.components != 3) {
    return imageError(name,
                      fmt::format("a JPEG of {} colour components is not supported", j.components));
  }
  std::array<int, 3> hs{}, vs{};
  int units = 0;
  for (int c = 0; c < j.components; ++c) {
    hs[size_t(c)] = byteAt(seg, 7 + 3 * size_t(c)) >> 4;
    vs[size_t(c)] = byteAt(seg, 7 + 3 * size_t(c)) & 15;
    if (hs[size_t(c)] < 1 || hs[size_t(c)] > 4 || vs[size_t(c)] < 1 || vs[size_t(c)] > 4) {
      return imageError(name, fmt::format("the JPEG's component {} has sampling factors {} x {} "
                                          "(1 to 4 each)",
                                          c, hs[size_t(c)], vs[size_t(c)]));
    }
    units += hs[size_t(c)] * vs[size_t(c)];
  }
  if (j.components > 1 && units > 10) {
    return imageError(name, "the JPEG's sampling factors need more than 10 blocks a unit");
  }
  // libjpeg's coefficient arrays (jdcoefct.c): per component, its blocks rounded up to whole
  // sampling units, 64 coefficients of 2 bytes each.
  const uint64_t hmax = uint64_t(*std::max_element(hs.begin(), hs.end()));
  const uint64_t vmax = uint64_t(*std::max_element(vs.begin(), vs.end()));
  for (int c = 0; c < j.components; ++c) {
    const uint64_t h = uint64_t(hs[size_t(c)]), v = uint64_t(vs[size_t(c)]);
    const uint64_t wb = ceilDiv(ceilDiv(uint64_t(j.width) * h, hmax * 8), h) * h;
    const uint64_t hb = ceilDiv(ceilDiv(uint64_t(j.height) * v, vmax * 8), v) * v;
    j.coefficient_bytes += wb * hb * 128;
  }
  return {};
}

Expected<JpegLayout> readJpegLayout(const std::string& name, std::string_view b) {
  JpegLayout j;
  size_t pos = 2;
  for (;;) {
    // Bytes before a marker other than 0xFF are damage libjpeg skips with a warning.
    while (pos < b.size() && byteAt(b, pos) != 0xff) ++pos;
    while (pos < b.size() && byteAt(b, pos) == 0xff) ++pos;
    if (pos >= b.size())
      return imageError(name, "the file is truncated: it ends before its image data");
    const int marker = byteAt(b, pos++);
    if (marker == 0x00 || marker == 0x01 || (marker >= 0xd0 && marker <= 0xd7)) continue;
    if (marker == 0xd8) return imageError(name, "the JPEG has a second start-of-image marker");
    if (marker == 0xd9)
      return imageError(name, "the JPEG ends before its first scan (no image data)");
    if (b.size() - pos < 2 || be16(b, pos) > b.size() - pos) {
      return imageError(name, fmt::format("the file is truncated: marker 0x{:02X} at byte {} runs "
                                          "past its end",
                                          marker, pos - 2));
    }
    const uint32_t length = be16(b, pos);
    if (length < 2) {
      return imageError(name, fmt::format("the JPEG's marker 0x{:02X} at byte {} has length {}",
                                          marker, pos - 2, length));
    }
    const std::string_view seg = b.substr(pos + 2, length - 2);
    const bool frame =
        marker >= 0xc0 && marker <= 0xcf && marker != 0xc4 && marker != 0xc8 && marker != 0xcc;
    if (frame) PENUMBRA_TRY(readJpegFrame(name, marker, seg, j));
    if (marker == 0xda) {
      if (j.components == 0) return imageError(name, "the JPEG has a scan before its frame header");
      if (seg.empty()) return imageError(name, "the JPEG's first scan header is empty");
      j.multi_scan = j.progressive || byteAt(seg, 0) < j.components;
      return j;
    }
    pos += length;
  }
}

Expected<ImageHeader> readJpegHeader(const std::string& name, std::string_view b) {
  Expected<JpegLayout> j = readJpegLayout(name, b);
  if (!j) return j.error();
  ImageHeader h;
  h.format = ImageFormat::kJpeg;
  h.width = j->width;
  h.height = j->height;
  h.channels = j->components;
  h.bits = 8;
  h.full_size_buffer_bytes = j->multi_scan ? j->coefficient_bytes : 0;
  // The scans, counted from the markers without decoding (entropy-coded data stuffs a 0x00
  // after every 0xFF, so 0xFF 0xDA is always a marker): a budget is checked from the header,
  // in a dry run too.
  if (j->multi_scan) {
    h.scans = 0;
    const auto* p = reinterpret_cast<const unsigned char*>(b.data());
    for (size_t i = 2; i + 1 < b.size(); ++i) {
      if (p[i] == 0xff && p[i + 1] == 0xda) ++h.scans;
    }
  }
  return h;
}

// ---- WebP header -----------------------------------------------------------------------------

std::string webpStatusMessage(VP8StatusCode status) {
  switch (status) {
    case VP8_STATUS_NOT_ENOUGH_DATA:
      return "the file is truncated: its WebP data ends early";
    case VP8_STATUS_UNSUPPORTED_FEATURE:
      return "the WebP uses a feature libwebp does not decode";
    case VP8_STATUS_OUT_OF_MEMORY:
      return "libwebp ran out of memory decoding it";
    case VP8_STATUS_BITSTREAM_ERROR:
      return "the WebP data is corrupt";
    default:
      return fmt::format("the WebP cannot be decoded (libwebp status {})", int(status));
  }
}

Expected<ImageHeader> readWebpHeader(const std::string& name, std::string_view b) {
  WebPBitstreamFeatures f;
  const VP8StatusCode status =
      WebPGetFeatures(reinterpret_cast<const uint8_t*>(b.data()), b.size(), &f);
  if (status != VP8_STATUS_OK) return imageError(name, webpStatusMessage(status));
  if (f.has_animation) return imageError(name, "an animated WebP is not supported");
  if (f.width < 1 || f.height < 1) return imageError(name, "the WebP has no pixels");
  ImageHeader h;
  h.format = ImageFormat::kWebp;
  h.width = f.width;
  h.height = f.height;
  h.channels = f.has_alpha ? 4 : 3;
  h.bits = 8;
  // libwebp (1.2, src/dec): a lossless image is decoded into a whole-image ARGB buffer (vp8l_dec.c
  // AllocateInternalBuffers32b); a lossy one streams macroblock rows, but its alpha plane is
  // decoded whole (alpha_dec.c), through an 8-bit lossless buffer as large again.
  const uint64_t pixels = uint64_t(f.width) * uint64_t(f.height);
  h.full_size_buffer_bytes = f.format == 2 ? 4 * pixels : f.has_alpha ? 2 * pixels : 0;
  return h;
}

// ---- BMP header ------------------------------------------------------------------------------

// A Windows or OS/2 bitmap (BITMAPFILEHEADER, then a BITMAPCOREHEADER of 12 bytes or a
// BITMAPINFOHEADER of 40 and its later versions of 52 to 124 bytes), uncompressed or with bit
// fields; rows bottom-up unless the height is negative, each padded to 4 bytes.
struct BmpLayout {
  uint32_t header_size = 0, compression = 0;
  int width = 0, height = 0, bpp = 0;
  bool top_down = false;
  size_t pixels_at = 0, stride = 0;
  size_t palette_at = 0, palette_entries = 0, palette_entry_bytes = 4;
  std::array<uint32_t, 4> masks{};  // R, G, B, A of a 16- or 32-bit pixel
};

Status readBmpMasks(const std::string& name, std::string_view b, BmpLayout& m, size_t& header_end) {
  if (m.bpp == 16 && m.compression == 0) {
    m.masks = {0x7c00, 0x03e0, 0x001f, 0};
  } else if (m.bpp == 32 && m.compression == 0) {
    // The fourth byte is alpha unless it is 0 everywhere, as browsers and stb_image read it.
    m.masks = {0xff0000, 0xff00, 0xff, 0};
    for (size_t y = 0; y < size_t(m.height) && m.masks[3] == 0; ++y) {
      const std::string_view row = b.substr(m.pixels_at + y * m.stride, 4 * size_t(m.width));
      for (size_t x = 3; x < row.size(); x += 4) {
        if (row[x] != 0) {
          m.masks[3] = 0xff000000u;
          break;
        }
      }
    }
  } else if (m.compression == 3 || m.compression == 6) {
    // BITFIELDS (and ALPHABITFIELDS): masks after a 40-byte header, inside a longer one.
    const size_t count = m.compression == 6 || m.header_size >= 56 ? 4 : 3;
    const size_t at = 14 + 40;
    if (m.header_size == 40) header_end += 4 * count;
    if (b.size() < at + 4 * count || header_end > m.pixels_at) {
      return imageError(name, "the BMP's bit masks run into its pixel data");
    }
    for (size_t c = 0; c < count; ++c) m.masks[c] = le32(b, at + 4 * c);
    if (m.masks[0] == 0 || m.masks[1] == 0 || m.masks[2] == 0) {
      return imageError(name, "the BMP's bit masks leave a colour out");
    }
  }
  return {};
}

Status readBmpFields(const std::string& name, std::string_view b, BmpLayout& m) {
  m.header_size = le32(b, 14);
  if (m.header_size != 12 && m.header_size != 40 && m.header_size != 52 && m.header_size != 56 &&
      m.header_size != 108 && m.header_size != 124) {
    return imageError(name,
                      fmt::format("a BMP header of {} bytes is not supported", m.header_size));
  }
  if (b.size() < 14 + m.header_size) {
    return imageError(name, fmt::format("the file is truncated: its {}-byte BMP header needs {} "
                                        "bytes, the file has {}",
                                        m.header_size, 14 + m.header_size, b.size()));
  }
  int64_t width = 0, height = 0;
  uint32_t planes = 0;
  if (m.header_size == 12) {
    width = le16(b, 18);
    height = le16(b, 20);
    planes = le16(b, 22);
    m.bpp = int(le16(b, 24));
  } else {
    width = int32_t(le32(b, 18));
    height = int32_t(le32(b, 22));
    planes = le16(b, 26);
    m.bpp = int(le16(b, 28));
    m.compression = le32(b, 30);
  }
  if (planes != 1) return imageError(name, fmt::format("the BMP has {} planes, not 1", planes));
  if (width < 1 || height == 0 || height == std::numeric_limits<int32_t>::min()) {
    return imageError(name, fmt::format("a BMP of {} x {} pixels has none", width, height));
  }
  m.top_down = height < 0;
  m.width = int(width);
  m.height = int(height < 0 ? -height : height);
  const uint32_t c = m.compression;
  if (c == 1 || c == 2) {
    return imageError(name, fmt::format("a run-length encoded BMP (RLE{}) is not supported: save "
                                        "it uncompressed",
                                        c == 1 ? 8 : 4));
  }
  if (c == 4 || c == 5) {
    return imageError(
        name, fmt::format("a BMP holding a {} image is not supported", c == 4 ? "JPEG" : "PNG"));
  }
  if (c != 0 && c != 3 && c != 6) {
    return imageError(name, fmt::format("unknown BMP compression {}", c));
  }
  const int bpp = m.bpp;
  if (bpp != 1 && bpp != 4 && bpp != 8 && bpp != 16 && bpp != 24 && bpp != 32) {
    return imageError(name, fmt::format("a BMP of {} bits a pixel is not supported", bpp));
  }
  if (c != 0 && bpp != 16 && bpp != 32) {
    return imageError(name, fmt::format("a {}-bit BMP cannot have bit fields", bpp));
  }
  if (m.top_down && m.header_size == 12) return imageError(name, "an OS/2 BMP cannot be top-down");
  return {};
}

Expected<BmpLayout> readBmpLayout(const std::string& name, std::string_view b) {
  if (b.size() < 18) {
    return imageError(name, fmt::format("the file is truncated: a BMP header needs at least 18 "
                                        "bytes, the file has {}",
                                        b.size()));
  }
  BmpLayout m;
  PENUMBRA_TRY(readBmpFields(name, b, m));
  m.pixels_at = le32(b, 10);
  m.stride = size_t((uint64_t(m.width) * uint64_t(m.bpp) + 31) / 32 * 4);
  size_t header_end = 14 + m.header_size;
  if (m.pixels_at < header_end || m.pixels_at > b.size()) {
    return imageError(name,
                      m.pixels_at > b.size()
                          ? fmt::format("the file is truncated: its pixel data would start at "
                                        "byte {}, past its end ({} bytes)",
                                        m.pixels_at, b.size())
                          : fmt::format("the BMP's pixel data starts at byte {}, inside its "
                                        "header",
                                        m.pixels_at));
  }
  // The last row's padding may be left out, as some writers do.
  const uint64_t need =
      uint64_t(m.stride) * uint64_t(m.height - 1) + ceilDiv(uint64_t(m.width) * uint64_t(m.bpp), 8);
  if (need > b.size() - m.pixels_at) {
    return imageError(
        name, fmt::format("the file is truncated: {} x {} pixels of {} bits need {} "
                          "bytes from byte {}, the file has {}",
                          m.width, m.height, m.bpp, need, m.pixels_at, b.size() - m.pixels_at));
  }
  PENUMBRA_TRY(readBmpMasks(name, b, m, header_end));
  if (m.bpp <= 8) {
    const uint32_t used = m.header_size == 12 ? 0 : le32(b, 46);
    m.palette_entry_bytes = m.header_size == 12 ? 3 : 4;
    m.palette_at = header_end;
    const size_t fits = (m.pixels_at - header_end) / m.palette_entry_bytes;
    m.palette_entries =
        std::min<size_t>({used == 0 ? size_t(1) << m.bpp : size_t(used), size_t(1) << m.bpp, fits});
    if (m.palette_entries == 0) return imageError(name, "the BMP has no palette");
  }
  return m;
}

Expected<ImageHeader> readBmpHeader(const std::string& name, std::string_view b) {
  Expected<BmpLayout> m = readBmpLayout(name, b);
  if (!m) return m.error();
  ImageHeader h;
  h.format = ImageFormat::kBmp;
  h.width = m->width;
  h.height = m->height;
  h.channels = m->masks[3] != 0 ? 4 : 3;
  h.bits = m->bpp;
  h.palette = m->bpp <= 8;
  return h;
}

// ---- TGA header ------------------------------------------------------------------------------

// A Truevision TGA (TGA 2.0 spec): an 18-byte header, an image ID, a colour map, then the pixels,
// raw or run-length encoded (packets of 1 to 128 pixels that may cross rows).
struct TgaLayout {
  int type = 0;  // 1 colour-mapped, 2 true colour, 3 grey (+8: run-length encoded)
  int map_length = 0, map_bits = 0;
  int width = 0, height = 0, bpp = 0;
  bool rle = false, top_down = false, right_to_left = false;
  size_t pixels_at = 0;
  int channels = 0;
  int64_t max_index = -1;  // the largest colour-map index a pixel uses
};

Status readTgaFields(const std::string& name, std::string_view b, TgaLayout& t) {
  const int map_type = byteAt(b, 1);
  t.type = byteAt(b, 2);
  const uint32_t map_first = le16(b, 3);
  t.map_length = int(le16(b, 5));
  t.map_bits = byteAt(b, 7);
  t.width = int(le16(b, 12));
  t.height = int(le16(b, 14));
  t.bpp = byteAt(b, 16);
  const int descriptor = byteAt(b, 17);
  t.top_down = (descriptor & 0x20) != 0;
  t.right_to_left = (descriptor & 0x10) != 0;
  t.rle = t.type >= 9;
  const int kind = t.rle ? t.type - 8 : t.type;
  if (t.type == 0) return imageError(name, "the TGA holds no image (image type 0)");
  if (t.type == 32 || t.type == 33) return imageError(name, "a Huffman-coded TGA is not supported");
  if (map_type > 1 || (kind != 1 && kind != 2 && kind != 3)) {
    return imageError(
        name, fmt::format("not a TGA image (colour map type {}, image type {})", map_type, t.type));
  }
  if (t.width < 1 || t.height < 1) {
    return imageError(name, fmt::format("a TGA of {} x {} pixels has none", t.width, t.height));
  }
  if (kind == 1) {
    if (map_type != 1 || t.map_length < 1) {
      return imageError(name, "a colour-mapped TGA without a colour map");
    }
    if (map_first != 0) {
      return imageError(
          name, fmt::format("a TGA colour map starting at entry {} is not supported", map_first));
    }
    const int mb = t.map_bits;
    if (mb != 8 && mb != 15 && mb != 16 && mb != 24 && mb != 32) {
      return imageError(name,
                        fmt::format("a TGA colour map of {}-bit entries is not supported", mb));
    }
    if (t.bpp != 8 && t.bpp != 16) {
      return imageError(
          name, fmt::format("a colour-mapped TGA of {}-bit indices is not supported", t.bpp));
    }
    t.channels = mb == 8 ? 1 : mb == 32 ? 4 : 3;
    return {};
  }
  if (map_type != 0)
    return imageError(name, "a TGA with a colour map it does not use is not supported");
  if (kind == 2 && t.bpp != 15 && t.bpp != 16 && t.bpp != 24 && t.bpp != 32) {
    return imageError(name,
                      fmt::format("a true-colour TGA of {} bits a pixel is not supported", t.bpp));
  }
  if (kind == 3 && t.bpp != 8 && t.bpp != 16) {
    return imageError(name, fmt::format("a grey TGA of {} bits a pixel is not supported", t.bpp));
  }
  t.channels = kind == 3 ? t.bpp / 8 : t.bpp == 32 ? 4 : 3;
  return {};
}

// Walks the pixel data as stb_image reads it, so that every pixel it reads is in the file, and
// notes the largest colour-map index.
Status walkTgaPixels(const std::string& name, std::string_view b, TgaLayout& t) {
  const size_t bytes_per_pixel = size_t(t.bpp + 7) / 8;
  const uint64_t pixels = uint64_t(t.width) * uint64_t(t.height);
  const bool mapped = t.type == 1 || t.type == 9;
  auto noteIndices = [&](size_t at, uint64_t count) {
    if (!mapped) return;
    for (uint64_t i = 0; i < count; ++i, at += bytes_per_pixel) {
      const uint32_t index = bytes_per_pixel == 1 ? byteAt(b, at) : le16(b, at);
      t.max_index = std::max<int64_t>(t.max_index, index);
    }
  };
  size_t pos = t.pixels_at;
  if (!t.rle) {
    const uint64_t need = pixels * bytes_per_pixel;
    if (need > b.size() - pos) {
      return imageError(name, fmt::format("the file is truncated: {} x {} pixels of {} bits need "
                                          "{} bytes, the file has {} after its header",
                                          t.width, t.height, t.bpp, need, b.size() - pos));
    }
    noteIndices(pos, pixels);
    return {};
  }
  for (uint64_t done = 0; done < pixels;) {
    if (pos >= b.size()) {
      return imageError(name, fmt::format("the file is truncated: its run-length encoded pixels "
                                          "end after {} of {} x {}",
                                          done, t.width, t.height));
    }
    const int packet = byteAt(b, pos++);
    const uint64_t count = uint64_t(packet & 127) + 1;
    const uint64_t values = (packet & 128) ? 1 : count;
    if (values * bytes_per_pixel > b.size() - pos) {
      return imageError(name, fmt::format("the file is truncated: a run-length packet at byte {} "
                                          "runs past its end",
                                          pos - 1));
    }
    noteIndices(pos, values);
    pos += values * bytes_per_pixel;
    done += count;
  }
  return {};
}

Expected<TgaLayout> readTgaLayout(const std::string& name, std::string_view b) {
  if (b.size() < 18) {
    return imageError(name, fmt::format("the file is truncated: a TGA header has 18 bytes, the "
                                        "file {}",
                                        b.size()));
  }
  if (b.size() > size_t(std::numeric_limits<int>::max())) {
    return imageError(name, "a TGA file over 2 GiB is not read");
  }
  TgaLayout t;
  PENUMBRA_TRY(readTgaFields(name, b, t));
  const size_t map_bytes =
      size_t(t.type == 1 || t.type == 9 ? t.map_length : 0) * size_t((t.map_bits + 7) / 8);
  t.pixels_at = 18 + size_t(byteAt(b, 0)) + map_bytes;
  if (t.pixels_at > b.size()) {
    return imageError(name, fmt::format("the file is truncated: its header, ID and colour map "
                                        "need {} bytes, the file has {}",
                                        t.pixels_at, b.size()));
  }
  PENUMBRA_TRY(walkTgaPixels(name, b, t));
  // stb_image decodes the whole image into one buffer, which it keeps under 2 GiB.
  if (uint64_t(t.width) * uint64_t(t.height) * uint64_t(t.channels) >
      uint64_t(std::numeric_limits<int>::max())) {
    return imageError(name, fmt::format("a TGA of {} x {} pixels is larger than its decoder takes "
                                        "(2 GiB decoded)",
                                        t.width, t.height));
  }
  return t;
}

Expected<ImageHeader> readTgaHeader(const std::string& name, std::string_view b) {
  Expected<TgaLayout> t = readTgaLayout(name, b);
  if (!t) return t.error();
  ImageHeader h;
  h.format = ImageFormat::kTga;
  h.width = t->width;
  h.height = t->height;
  h.channels = t->channels;
  h.bits = t->bpp;
  h.palette = t->type == 1 || t->type == 9;
  h.full_size_buffer_bytes = uint64_t(t->width) * uint64_t(t->height) * uint64_t(t->channels);
  return h;
}

}  // namespace

Expected<ImageHeader> readImageHeader(const std::string& name, std::string_view bytes) {
  if (bytes.empty()) return imageError(name, "the file is empty");
  switch (imageFormatOf(name, bytes)) {
    case ImageFormat::kPng:
      return readPngHeader(name, bytes);
    case ImageFormat::kJpeg:
      return readJpegHeader(name, bytes);
    case ImageFormat::kWebp:
      return readWebpHeader(name, bytes);
    case ImageFormat::kBmp:
      return readBmpHeader(name, bytes);
    case ImageFormat::kTga:
      return readTgaHeader(name, bytes);
    case ImageFormat::kKtx2:
      return imageError(name,
                        "a KTX2 texture (Basis Universal) is not supported: use a PNG, JPEG "
                        "or WebP image");
    case ImageFormat::kUnknown:
      break;
  }
  return imageError(name, unknownFormatMessage(bytes));
}

// ---- planning --------------------------------------------------------------------------------

namespace {

// What a decoder holds besides its output: the whole-image buffer some formats need, its rows,
// the reducer's sums, and a MiB for tables and state (zlib's window, Huffman tables).
uint64_t decoderBytes(const ImageHeader& h, uint64_t factor, uint64_t out_width,
                      uint64_t out_height) {
  const uint64_t w = uint64_t(h.width);
  const uint64_t sample = h.sixteen_bit ? 2 : 1;
  uint64_t bytes = h.full_size_buffer_bytes + (1u << 20) + 4 * w * sample + 32 * out_width;
  switch (h.format) {
    case ImageFormat::kPng:
      // libpng's current and previous rows, as read and as transformed.
      bytes += 3 * 4 * w * sample;
      if (h.interlaced && factor > 1) bytes += 16 * out_width * out_height;
      break;
    case ImageFormat::kJpeg:
      // libjpeg's per-row buffers: up to 4 block rows a component before and after upsampling.
      bytes += 64 * w * uint64_t(h.channels) + 4 * 64 * ceilDiv(w, std::min<uint64_t>(factor, 8));
      break;
    case ImageFormat::kWebp:
      bytes += 64 * 4 * w;  // row caches and the rescaler
      break;
    default:
      break;
  }
  return bytes;
}

}  // namespace

ImagePlan planImage(const ImageHeader& header, const ImageLimits& limits) {
  const uint64_t f =
      reductionFactor(uint64_t(header.width), uint64_t(header.height), limits.max_size);
  ImagePlan plan;
  plan.width = int(ceilDiv(uint64_t(header.width), f));
  plan.height = int(ceilDiv(uint64_t(header.height), f));
  plan.reduced = f > 1;
  plan.texture_bytes = Texture::plannedBytes(plan.width, plan.height, header.sixteen_bit);
  const uint64_t texels =
      4 * uint64_t(plan.width) * uint64_t(plan.height) * (header.sixteen_bit ? 2 : 1);
  // Texture::fromRgba16 copies the texels; fromRgba8 takes them over.
  plan.peak_bytes = decoderBytes(header, f, uint64_t(plan.width), uint64_t(plan.height)) + texels +
                    plan.texture_bytes + (header.sixteen_bit ? texels : 0);
  return plan;
}

ImagePlan planDataImage(const ImageHeader& header, const ImageLimits& limits) {
  const uint64_t f =
      reductionFactor(uint64_t(header.width), uint64_t(header.height), limits.max_size);
  ImagePlan plan;
  plan.width = int(ceilDiv(uint64_t(header.width), f));
  plan.height = int(ceilDiv(uint64_t(header.height), f));
  plan.reduced = f > 1;
  const uint64_t pixels = uint64_t(plan.width) * uint64_t(plan.height);
  plan.texture_bytes = pixels * sizeof(glm::vec3);
  // libwebp decodes into RGBA texels first.
  plan.peak_bytes = decoderBytes(header, f, uint64_t(plan.width), uint64_t(plan.height)) +
                    plan.texture_bytes + (header.format == ImageFormat::kWebp ? 4 * pixels : 0);
  return plan;
}

uint64_t plannedSceneBytes(std::span<const ImagePlan> plans) {
  uint64_t kept = 0, transient = 0;
  for (const ImagePlan& p : plans) {
    kept += p.texture_bytes;
    transient = std::max(transient, p.peak_bytes - std::min(p.peak_bytes, p.texture_bytes));
  }
  return kept + transient;
}

namespace {

// ---- PNG decoding (libpng) -------------------------------------------------------------------

// Shared with libpng's callbacks, which may longjmp: plain data only.
struct PngIo {
  const unsigned char* data = nullptr;
  size_t size = 0, pos = 0;
  char error[256] = {};
  std::array<std::array<char, 200>, 4> warnings{};
  int warning_count = 0;
  const Deadline* deadline = nullptr;
  bool timed_out = false;
};

void pngReadData(png_structp png, png_bytep out, size_t n) {
  PngIo& io = *static_cast<PngIo*>(png_get_io_ptr(png));
  if (n > io.size - io.pos) png_error(png, "the file ends early");
  std::memcpy(out, io.data + io.pos, n);
  io.pos += n;
}

[[noreturn]] void pngError(png_structp png, png_const_charp message) {
  PngIo& io = *static_cast<PngIo*>(png_get_error_ptr(png));
  if (io.error[0] == 0) std::snprintf(io.error, sizeof io.error, "%s", message);
  png_longjmp(png, 1);
}

void pngWarning(png_structp png, png_const_charp message) {
  PngIo& io = *static_cast<PngIo*>(png_get_error_ptr(png));
  if (io.warning_count < int(io.warnings.size())) {
    std::snprintf(io.warnings[size_t(io.warning_count)].data(), io.warnings[0].size(), "%s",
                  message);
  }
  ++io.warning_count;
}

void pngCheckTime(png_structp png, PngIo& io) {
  if (io.deadline->passed()) {
    io.timed_out = true;
    png_error(png, "time");
  }
}

// Chunks Penumbra does not use, skipped unread (their CRCs are still checked): textures are sRGB
// whatever their gamma, ICC or chromaticity chunks say, and text may be large.
constexpr png_byte kIgnoredPngChunks[] =
    "bKGD\0cHRM\0eXIf\0gAMA\0hIST\0iCCP\0iTXt\0oFFs\0pCAL\0pHYs\0sBIT\0sCAL\0sPLT\0sRGB\0tEXt\0"
    "tIME\0zTXt";

// libpng's transformations to 8 or 16 bits a sample (16 in host byte order), tRNS expanded to
// alpha; grey stays grey (BoxReducer expands it to RGBA after reducing). Palette indices come one
// to a byte and are looked up here (pngLookUp): libpng's own expansion would not say whether an
// index is past the palette.
void pngSetTransforms(png_structp png, png_infop info) {
  const int type = png_get_color_type(png, info);
  const int depth = png_get_bit_depth(png, info);
  if (type == PNG_COLOR_TYPE_PALETTE) {
    png_set_packing(png);
  } else {
    if (type == PNG_COLOR_TYPE_GRAY && depth < 8) png_set_expand_gray_1_2_4_to_8(png);
    if (png_get_valid(png, info, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(png);
  }
  if (depth == 16 && std::endian::native == std::endian::little) png_set_swap(png);
}

// A palette as 256 RGBA entries: PLTE's colours, tRNS's alphas (255 past them), and opaque black
// past the palette (as libpng's own expansion reads its zeroed 256-entry palette). Returns the
// channels of a looked-up pixel: 4 with tRNS, else 3.
int pngPaletteTable(png_structp png, png_infop info, std::array<uint8_t, 1024>& table,
                    int& entries) {
  png_colorp colours = nullptr;
  png_bytep alphas = nullptr;
  int alpha_count = 0;
  png_color_16p unused = nullptr;
  png_get_PLTE(png, info, &colours, &entries);
  const bool trns = png_get_tRNS(png, info, &alphas, &alpha_count, &unused) != 0 && alphas;
  for (int i = 0; i < 256; ++i) {
    uint8_t* e = &table[4 * size_t(i)];
    const bool known = i < entries;
    e[0] = known ? colours[i].red : 0;
    e[1] = known ? colours[i].green : 0;
    e[2] = known ? colours[i].blue : 0;
    e[3] = trns && i < alpha_count ? alphas[i] : 255;
  }
  return trns ? 4 : 3;
}

template <typename T>
struct PngJob {
  png_structp png = nullptr;
  png_infop info = nullptr;
  PngIo* io = nullptr;
  uint32_t width = 0, height = 0;
  bool interlaced = false;
  T* row = nullptr;  // one row of RGBA
  BoxReducer<T>* rows = nullptr;
  PixelSums<T>* pixels = nullptr;
  int colour_type = 0;  // as stored
  int channels = 0;     // as decoded: 1 to 4
  // Palette images: the lookup table, the looked-up row, the palette's size, the largest index.
  std::array<uint8_t, 1024> palette{};
  T* looked_up = nullptr;
  int palette_entries = 0, max_index = -1;
};

// The decoded pixels of the row just read, `count` of them: palette indices looked up.
template <typename T>
const T* pngPixels(PngJob<T>& job, size_t count) {
  if (job.colour_type != PNG_COLOR_TYPE_PALETTE) return job.row;
  const size_t n = size_t(job.channels);
  for (size_t i = 0; i < count; ++i) {
    const uint8_t index = uint8_t(job.row[i]);
    job.max_index = std::max<int>(job.max_index, index);
    std::memcpy(&job.looked_up[n * i], &job.palette[4 * size_t(index)], n * sizeof(T));
  }
  return job.looked_up;
}

// A plain image's rows. Not inlined into pngRun, whose frame holds setjmp's buffer.
template <typename T>
[[gnu::noinline]] void pngReadRows(PngJob<T>& job) {
  for (uint32_t y = 0; y < job.height; ++y) {
    png_read_row(job.png, reinterpret_cast<png_bytep>(job.row), nullptr);
    job.rows->add(pngPixels(job, job.width));
    pngCheckTime(job.png, *job.io);
  }
}

// An interlaced image's seven passes (PNG spec, 8.2), each a small image of its own, read as they
// come: libpng's own de-interlacing would need the whole image.
template <typename T>
[[gnu::noinline]] void pngReadPasses(PngJob<T>& job) {
  for (int pass = 0; pass < 7; ++pass) {
    const uint32_t cols = PNG_PASS_COLS(job.width, pass);
    const uint32_t rows = PNG_PASS_ROWS(job.height, pass);
    if (cols == 0 || rows == 0) continue;  // libpng skips empty passes too
    for (uint32_t r = 0; r < rows; ++r) {
      png_read_row(job.png, reinterpret_cast<png_bytep>(job.row), nullptr);
      const T* pixels = pngPixels(job, cols);
      const uint64_t y = PNG_PASS_START_ROW(pass) + uint64_t(r) * PNG_PASS_ROW_OFFSET(pass);
      for (uint32_t i = 0; i < cols; ++i) {
        const uint64_t x = PNG_PASS_START_COL(pass) + uint64_t(i) * PNG_PASS_COL_OFFSET(pass);
        job.pixels->add(x, y, pixels + size_t(job.channels) * i);
      }
      pngCheckTime(job.png, *job.io);
    }
  }
}

// Calls setjmp: false after a libpng error (PngIo::error says which).
template <typename T>
bool pngRun(PngJob<T>& job) {
  if (setjmp(png_jmpbuf(job.png))) return false;
  png_set_read_fn(job.png, job.io, pngReadData);
  // The header reader checked the size against the format's limits and the image data.
  png_set_user_limits(job.png, 0x7fffffff, 0x7fffffff);
  // Critical chunks with a bad CRC are errors; the others, which Penumbra does not use, are
  // dropped with a warning (IHDR, PLTE and tRNS were checked with the header).
  png_set_crc_action(job.png, PNG_CRC_ERROR_QUIT, PNG_CRC_WARN_DISCARD);
  png_set_keep_unknown_chunks(job.png, PNG_HANDLE_CHUNK_NEVER, nullptr, 0);
  png_set_keep_unknown_chunks(job.png, PNG_HANDLE_CHUNK_NEVER, kIgnoredPngChunks,
                              int(sizeof kIgnoredPngChunks / 5));
  png_read_info(job.png, job.info);
  job.colour_type = png_get_color_type(job.png, job.info);
  pngSetTransforms(job.png, job.info);
  png_read_update_info(job.png, job.info);
  const size_t samples = png_get_channels(job.png, job.info);
  if (samples < 1 || samples > 4 ||
      png_get_rowbytes(job.png, job.info) != size_t(job.width) * samples * sizeof(T)) {
    png_error(job.png, "unexpected row size after transformations");
  }
  job.channels = job.colour_type == PNG_COLOR_TYPE_PALETTE
                     ? pngPaletteTable(job.png, job.info, job.palette, job.palette_entries)
                     : int(samples);
  job.rows->setChannels(job.channels);
  job.pixels->setChannels(job.channels);
  if (job.interlaced) {
    pngReadPasses(job);
  } else {
    pngReadRows(job);
  }
  png_read_end(job.png, nullptr);
  return true;
}

// libpng's words for what went wrong, in the user's.
std::string pngErrorMessage(const PngIo& io, const ImageLimits& limits) {
  const std::string what = io.error;
  if (io.timed_out) return timeMessage(limits.max_seconds);
  if (what.find("CRC error") != std::string::npos) {
    return fmt::format("the file is damaged: chunk {} fails its CRC check", what.substr(0, 4));
  }
  if (what == "the file ends early" || what.find("Not enough image data") != std::string::npos) {
    return "the file is truncated: its image data ends before its last row";
  }
  if (what.find("Insufficient memory") != std::string::npos ||
      what.find("Out of memory") != std::string::npos) {
    return "libpng ran out of memory decoding it";
  }
  return "the PNG is corrupt (libpng: " + what + ")";
}

void pngNoteWarnings(const PngIo& io, int palette_entries, int palette_max,
                     std::vector<std::string>& warnings) {
  for (int i = 0; i < std::min<int>(io.warning_count, int(io.warnings.size())); ++i) {
    const std::string w = io.warnings[size_t(i)].data();
    if (w.find("palette index exceeding") != std::string::npos) continue;  // said below
    if (w.find("CRC error") != std::string::npos) {
      warnings.push_back(
          fmt::format("chunk {} fails its CRC check: ignored (Penumbra does not use "
                      "it)",
                      w.substr(0, 4)));
    } else {
      warnings.push_back("libpng: " + w);
    }
  }
  if (palette_entries > 0 && palette_max >= palette_entries) {
    warnings.push_back(
        fmt::format("pixels use colour {}, past the {} of its palette: they read as "
                    "opaque black",
                    palette_max, palette_entries));
  }
}

template <typename T>
Status decodePngAs(DecodeJob& d, PngIo& io) {
  struct Structs {
    png_structp png = nullptr;
    png_infop info = nullptr;
    ~Structs() { png_destroy_read_struct(&png, info ? &info : nullptr, nullptr); }
  } s;
  s.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &io, pngError, pngWarning);
  if (s.png) s.info = png_create_info_struct(s.png);
  if (!s.png || !s.info) return runtimeError(d.name, "libpng ran out of memory");
  // Room for 4 channels: libpng says how many it hands over once it has read the header.
  std::vector<T> row(4 * size_t(d.header.width));
  std::vector<T> looked_up(d.header.palette ? 4 * size_t(d.header.width) : 0);
  BoxReducer<T> rows(d.header.width, d.header.height, d.factor, 4, d.out);
  PixelSums<T> pixels(d.header.width, d.header.interlaced ? d.header.height : 1,
                      d.header.interlaced ? d.factor : 1, 4, d.out);
  PngJob<T> job;
  job.png = s.png;
  job.info = s.info;
  job.io = &io;
  job.width = uint32_t(d.header.width);
  job.height = uint32_t(d.header.height);
  job.interlaced = d.header.interlaced;
  job.row = row.data();
  job.looked_up = looked_up.data();
  job.rows = &rows;
  job.pixels = &pixels;
  if (!pngRun(job)) return imageError(d.name, pngErrorMessage(io, d.limits));
  if (job.interlaced) pixels.finish();
  pngNoteWarnings(io, job.palette_entries, job.max_index, d.warnings);
  d.channels = job.channels;
  return {};
}

Status decodePng(DecodeJob& d) {
  if (d.header.interlaced && d.factor > 256) {
    return imageError(d.name, fmt::format("an interlaced PNG more than 256 times the size limit a "
                                          "side ({} x {}, limit {}) is not reduced",
                                          d.header.width, d.header.height, d.limits.max_size));
  }
  PngIo io;
  io.data = reinterpret_cast<const unsigned char*>(d.bytes.data());
  io.size = d.bytes.size();
  io.deadline = &d.deadline;
  return d.header.sixteen_bit ? decodePngAs<uint16_t>(d, io) : decodePngAs<uint8_t>(d, io);
}

// ---- JPEG decoding (libjpeg-turbo) -----------------------------------------------------------
//
// Under valgrind, libjpeg-turbo's SIMD routines for scaled decoding read the padding of their row
// buffers, which memcheck reports as output that depends on uninitialised memory; the texels are
// the same whatever the padding holds (checked with MALLOC_PERTURB_). Run memcheck with
// JSIMD_FORCENONE=1.

// libjpeg's state and what its callbacks need; they longjmp, so plain data only.
struct JpegJob {
  jpeg_decompress_struct cinfo;
  jpeg_error_mgr err;
  jpeg_progress_mgr progress;
  std::jmp_buf jump;
  char error[JMSG_LENGTH_MAX] = {};
  int error_code = 0;
  char warning[JMSG_LENGTH_MAX] = {};
  long warnings = 0;
  int max_scans = 0;
  bool scans_exceeded = false, timed_out = false;
  const Deadline* deadline = nullptr;
  uint64_t max_memory = 0;
  unsigned scale = 1;
  unsigned expected_width = 0, expected_height = 0;
  int channels = 3;  // 1 grey, 3 RGB
  uint8_t* row = nullptr;
  BoxReducer<uint8_t>* rows = nullptr;
};

JpegJob& jpegJobOf(j_common_ptr c) {
  return *static_cast<JpegJob*>(c->client_data);
}

[[noreturn]] void jpegFail(JpegJob& job) {
  std::longjmp(job.jump, 1);
}

[[noreturn]] void jpegFailWith(JpegJob& job, const char* message) {
  std::snprintf(job.error, sizeof job.error, "%s", message);
  job.error_code = -1;
  jpegFail(job);
}

[[noreturn]] void jpegErrorExit(j_common_ptr c) {
  JpegJob& job = jpegJobOf(c);
  if (job.error[0] == 0) {
    (*c->err->format_message)(c, job.error);
    job.error_code = c->err->msg_code;
  }
  jpegFail(job);
}

// Warnings about data that is missing or cannot be decoded stop the decoding: libjpeg would fill
// the rest with grey. Other warnings (stray bytes between markers, an odd progression) are
// passed on.
void jpegEmitMessage(j_common_ptr c, int level) {
  if (level >= 0) return;  // trace messages
  JpegJob& job = jpegJobOf(c);
  const int code = c->err->msg_code;
  if (code == JWRN_JPEG_EOF || code == JWRN_HIT_MARKER || code == JWRN_HUFF_BAD_CODE ||
      code == JWRN_ARITH_BAD_CODE || code == JWRN_MUST_RESYNC) {
    jpegErrorExit(c);
  }
  if (job.warnings++ == 0) (*c->err->format_message)(c, job.warning);
}

// Called at least once per scan while libjpeg reads a multi-scan image, and per row after.
void jpegProgress(j_common_ptr c) {
  JpegJob& job = jpegJobOf(c);
  const auto* d = reinterpret_cast<j_decompress_ptr>(c);
  if (d->input_scan_number > job.max_scans) {
    job.scans_exceeded = true;
    jpegFail(job);
  }
  if (job.deadline->passed()) {
    job.timed_out = true;
    jpegFail(job);
  }
}

// Calls setjmp: false after an error (JpegJob says which).
bool jpegRun(JpegJob& job, const unsigned char* data, size_t size) {
  if (setjmp(job.jump)) return false;
  jpeg_create_decompress(&job.cinfo);
  // Virtual arrays (the coefficient buffer) beyond this fail instead of growing: the plan counted
  // them.
  job.cinfo.mem->max_memory_to_use = long(std::min<uint64_t>(job.max_memory, LONG_MAX));
  job.cinfo.progress = &job.progress;
  jpeg_mem_src(&job.cinfo, data, static_cast<unsigned long>(size));
  jpeg_read_header(&job.cinfo, TRUE);
  job.cinfo.out_color_space = job.channels == 1 ? JCS_GRAYSCALE : JCS_RGB;
  job.cinfo.scale_num = 1;
  job.cinfo.scale_denom = job.scale;
  jpeg_start_decompress(&job.cinfo);
  if (job.cinfo.output_width != job.expected_width ||
      job.cinfo.output_height != job.expected_height ||
      job.cinfo.output_components != job.channels) {
    jpegFailWith(job, "libjpeg decodes it at another size than its header gives");
  }
  while (job.cinfo.output_scanline < job.cinfo.output_height) {
    JSAMPROW row = job.row;
    if (jpeg_read_scanlines(&job.cinfo, &row, 1) != 1) jpegFailWith(job, "no row came out");
    job.rows->add(job.row);
  }
  jpeg_finish_decompress(&job.cinfo);
  return true;
}

std::string jpegErrorMessage(const JpegJob& job, const ImageLimits& limits) {
  if (job.scans_exceeded) {
    return fmt::format(
        "the JPEG has more than {} scans (a progressive JPEG has about 10; each "
        "scan rereads the whole image): decoding stopped at scan {}",
        limits.max_scans, limits.max_scans + 1);
  }
  if (job.timed_out) return timeMessage(limits.max_seconds);
  switch (job.error_code) {
    case JWRN_JPEG_EOF:
      return "the file is truncated: its JPEG data ends early";
    case JWRN_HIT_MARKER:
      return "the JPEG's image data is cut short or corrupt (libjpeg: premature end of data "
             "segment)";
    case JERR_NO_BACKING_STORE:
    case JERR_OUT_OF_MEMORY:
      return "libjpeg needed more memory than planned for it";
    default:
      return std::string("the JPEG is corrupt (libjpeg: ") + job.error + ")";
  }
}

Status decodeJpeg(DecodeJob& d) {
  auto job = std::make_unique<JpegJob>();
  std::memset(&job->cinfo, 0, sizeof job->cinfo);
  job->cinfo.err = jpeg_std_error(&job->err);
  job->err.error_exit = jpegErrorExit;
  job->err.emit_message = jpegEmitMessage;
  job->cinfo.client_data = job.get();
  job->progress = {};
  job->progress.progress_monitor = jpegProgress;
  job->max_scans = d.limits.max_scans;
  job->deadline = &d.deadline;
  job->max_memory =
      d.header.full_size_buffer_bytes + 64 * uint64_t(d.header.width) * 4 + (uint64_t(32) << 20);
  // libjpeg scales by up to 8 in the DCT; the rest is a box filter on its rows.
  job->scale = unsigned(std::min<uint64_t>(d.factor, 8));
  job->expected_width = unsigned(ceilDiv(uint64_t(d.header.width), job->scale));
  job->expected_height = unsigned(ceilDiv(uint64_t(d.header.height), job->scale));
  job->channels = d.header.channels;
  std::vector<uint8_t> row(size_t(job->channels) * size_t(job->expected_width));
  BoxReducer<uint8_t> rows(int(job->expected_width), int(job->expected_height),
                           d.factor / job->scale, job->channels, d.out);
  job->row = row.data();
  job->rows = &rows;
  const bool ok =
      jpegRun(*job, reinterpret_cast<const unsigned char*>(d.bytes.data()), d.bytes.size());
  jpeg_destroy_decompress(&job->cinfo);
  if (!ok) return imageError(d.name, jpegErrorMessage(*job, d.limits));
  if (job->warnings > 0) {
    d.warnings.push_back(fmt::format(
        "libjpeg: {}{}", job->warning,
        job->warnings > 1 ? fmt::format(" (and {} more warnings)", job->warnings - 1) : ""));
  }
  return {};
}

// ---- WebP decoding (libwebp) -----------------------------------------------------------------

Status decodeWebp(DecodeJob& d, uint8_t* rgba) {
  WebPDecoderConfig config;
  if (!WebPInitDecoderConfig(&config)) return runtimeError(d.name, "libwebp version mismatch");
  if (d.factor > 1) {
    config.options.use_scaling = 1;
    config.options.scaled_width = d.out.width();
    config.options.scaled_height = d.out.height();
  }
  config.output.colorspace = MODE_RGBA;
  config.output.is_external_memory = 1;
  config.output.u.RGBA.rgba = rgba;
  config.output.u.RGBA.stride = 4 * d.out.width();
  config.output.u.RGBA.size = 4 * size_t(d.out.width()) * size_t(d.out.height());
  const VP8StatusCode status =
      WebPDecode(reinterpret_cast<const uint8_t*>(d.bytes.data()), d.bytes.size(), &config);
  WebPFreeDecBuffer(&config.output);
  if (status != VP8_STATUS_OK) return imageError(d.name, webpStatusMessage(status));
  return {};
}

// ---- BMP decoding ----------------------------------------------------------------------------

// A bit field's value scaled to 8 bits: the full-scale value is the mask shifted down.
struct BmpChannel {
  uint32_t mask = 0;
  int shift = 0;
  uint64_t full = 0;
  uint8_t operator()(uint32_t v) const {
    if (full == 0) return 255;
    return uint8_t((uint64_t((v & mask) >> shift) * 255 + full / 2) / full);
  }
};

// One row of a BMP as RGBA; returns the largest palette index it uses.
int64_t bmpRow(const BmpLayout& m, std::string_view b, const std::array<BmpChannel, 4>& ch,
               size_t file_row, uint8_t* rgba) {
  const std::string_view row = b.substr(m.pixels_at + file_row * m.stride);
  int64_t max_index = -1;
  for (size_t x = 0; x < size_t(m.width); ++x) {
    uint8_t* out = rgba + 4 * x;
    if (m.bpp <= 8) {
      const size_t bit = x * size_t(m.bpp);
      const uint32_t index = (byteAt(row, bit / 8) >> (8 - m.bpp - bit % 8)) & ((1u << m.bpp) - 1);
      max_index = std::max<int64_t>(max_index, index);
      if (index < m.palette_entries) {
        const size_t at = m.palette_at + index * m.palette_entry_bytes;
        out[0] = byteAt(b, at + 2);
        out[1] = byteAt(b, at + 1);
        out[2] = byteAt(b, at);
      } else {
        out[0] = out[1] = out[2] = 0;
      }
      out[3] = 255;
    } else if (m.bpp == 24) {
      out[0] = byteAt(row, 3 * x + 2);
      out[1] = byteAt(row, 3 * x + 1);
      out[2] = byteAt(row, 3 * x);
      out[3] = 255;
    } else {
      const uint32_t v = m.bpp == 16 ? le16(row, 2 * x) : le32(row, 4 * x);
      for (size_t c = 0; c < 4; ++c) out[c] = ch[c](v);
    }
  }
  return max_index;
}

Status decodeBmp(DecodeJob& d) {
  Expected<BmpLayout> layout = readBmpLayout(d.name, d.bytes);
  if (!layout) return layout.error();
  const BmpLayout& m = *layout;
  std::array<BmpChannel, 4> channels;
  for (size_t c = 0; c < 4; ++c) {
    BmpChannel& ch = channels[c];
    ch.mask = m.masks[c];
    ch.shift = ch.mask ? std::countr_zero(ch.mask) : 0;
    ch.full = ch.mask >> ch.shift;
  }
  std::vector<uint8_t> row(4 * size_t(m.width));
  BoxReducer<uint8_t> rows(m.width, m.height, d.factor, 4, d.out);
  int64_t max_index = -1;
  for (size_t y = 0; y < size_t(m.height); ++y) {
    const size_t file_row = m.top_down ? y : size_t(m.height) - 1 - y;
    max_index = std::max(max_index, bmpRow(m, d.bytes, channels, file_row, row.data()));
    rows.add(row.data());
  }
  if (m.bpp <= 8 && max_index >= int64_t(m.palette_entries)) {
    d.warnings.push_back(
        fmt::format("pixels use colour {}, past the {} of its palette: they read "
                    "as opaque black",
                    max_index, m.palette_entries));
  }
  return {};
}

// ---- TGA decoding (stb_image) ----------------------------------------------------------------

Status decodeTga(DecodeJob& d) {
  Expected<TgaLayout> layout = readTgaLayout(d.name, d.bytes);
  if (!layout) return layout.error();
  const TgaLayout& t = *layout;
  int w = 0, h = 0, comp = 0;
  std::unique_ptr<stbi_uc, void (*)(void*)> pixels(
      stbi_load_from_memory(reinterpret_cast<const stbi_uc*>(d.bytes.data()), int(d.bytes.size()),
                            &w, &h, &comp, 0),
      stbi_image_free);
  if (!pixels) {
    const std::string why = stbi_failure_reason();
    return imageError(d.name, why == "outofmem"
                                  ? std::string("stb_image ran out of memory decoding it")
                                  : "the TGA cannot be decoded (stb_image: " + why + ")");
  }
  if (w != t.width || h != t.height || comp != t.channels) {
    return imageError(d.name, "the TGA decodes to another size than its header says");
  }
  // stb_image ignores the descriptor's right-to-left bit: mirror such rows here.
  std::vector<uint8_t> mirrored(t.right_to_left ? size_t(w) * size_t(comp) : 0);
  BoxReducer<uint8_t> rows(w, h, d.factor, comp, d.out);
  for (size_t y = 0; y < size_t(h); ++y) {
    const stbi_uc* in = pixels.get() + y * size_t(w) * size_t(comp);
    if (!t.right_to_left) {
      rows.add(in);
      continue;
    }
    for (size_t x = 0; x < size_t(w); ++x) {
      std::memcpy(&mirrored[x * size_t(comp)], in + (size_t(w) - 1 - x) * size_t(comp),
                  size_t(comp));
    }
    rows.add(mirrored.data());
  }
  if ((t.type == 1 || t.type == 9) && t.max_index >= t.map_length) {
    d.warnings.push_back(
        fmt::format("pixels use colour {}, past the {} of its colour map: they "
                    "read as its first colour",
                    t.max_index, t.map_length));
  }
  return {};
}

// ---- decoding, whatever the format --------------------------------------------------------------

Status decodePixels(DecodeJob& d, uint8_t* webp_rgba) {
  switch (d.header.format) {
    case ImageFormat::kPng:
      return decodePng(d);
    case ImageFormat::kJpeg:
      return decodeJpeg(d);
    case ImageFormat::kWebp:
      return decodeWebp(d, webp_rgba);
    case ImageFormat::kBmp:
      return decodeBmp(d);
    case ImageFormat::kTga:
      return decodeTga(d);
    default:
      break;
  }
  return imageError(d.name, "not an image format Penumbra decodes");
}

// "16384 x 16384 16-bit PNG (reduced to 8192 x 8192)".
std::string describe(const ImageHeader& h, const ImagePlan& plan) {
  std::string out = fmt::format("{} x {} {}{}", h.width, h.height, h.sixteen_bit ? "16-bit " : "",
                                imageFormatName(h.format));
  if (plan.reduced) out += fmt::format(" (reduced to {} x {})", plan.width, plan.height);
  return out;
}

std::string reductionWarning(const ImageHeader& h, const ImagePlan& plan, const ImageLimits& l) {
  return fmt::format(
      "reduced from {} x {} to {} x {}: larger than the texture size limit ({} a side)", h.width,
      h.height, plan.width, plan.height, l.max_size);
}

Status checkPlan(const std::string& name, const ImageHeader& header, const ImagePlan& plan) {
  if (Status m = checkMemory(plan.peak_bytes, "decoding this " + describe(header, plan)); !m.ok()) {
    return imageError(name, m.error().message);
  }
  return {};
}

Expected<TextureTexels> decodeTexture(const std::string& name, std::string_view bytes,
                                      const ImageLimits& limits) {
  Expected<ImageHeader> header = readImageHeader(name, bytes);
  if (!header) return header.error();
  const ImagePlan plan = planImage(*header, limits);
  PENUMBRA_TRY(checkPlan(name, *header, plan));
  TextureTexels t;
  t.width = plan.width;
  t.height = plan.height;
  t.file_width = header->width;
  t.file_height = header->height;
  t.sixteen_bit = header->sixteen_bit;
  const size_t samples = 4 * size_t(plan.width) * size_t(plan.height);
  if (t.sixteen_bit) {
    t.rgba16.resize(samples);
  } else {
    t.rgba8.resize(samples);
  }
  TexelOutput out(plan.width, plan.height, &t, nullptr);
  DecodeJob d{name,
              bytes,
              *header,
              limits,
              reductionFactor(uint64_t(header->width), uint64_t(header->height), limits.max_size),
              out,
              t.warnings,
              Deadline(limits.max_seconds),
              header->channels};
  if (plan.reduced) t.warnings.push_back(reductionWarning(*header, plan, limits));
  PENUMBRA_TRY(decodePixels(d, t.rgba8.data()));
  t.channels = d.channels;
  return t;
}

Expected<Image> decodeData(const std::string& name, std::string_view bytes,
                           const ImageLimits& limits, std::vector<std::string>& warnings) {
  Expected<ImageHeader> header = readImageHeader(name, bytes);
  if (!header) return header.error();
  const ImagePlan plan = planDataImage(*header, limits);
  PENUMBRA_TRY(checkPlan(name, *header, plan));
  Image image(plan.width, plan.height);
  TexelOutput out(plan.width, plan.height, nullptr, &image);
  DecodeJob d{name,
              bytes,
              *header,
              limits,
              reductionFactor(uint64_t(header->width), uint64_t(header->height), limits.max_size),
              out,
              warnings,
              Deadline(limits.max_seconds),
              header->channels};
  const auto first = std::ptrdiff_t(warnings.size());
  if (header->format != ImageFormat::kWebp) {
    PENUMBRA_TRY(decodePixels(d, nullptr));
  } else {
    // libwebp writes whole RGBA images: decode into texels, then convert.
    std::vector<uint8_t> rgba(4 * size_t(plan.width) * size_t(plan.height));
    PENUMBRA_TRY(decodePixels(d, rgba.data()));
    for (int y = 0; y < plan.height; ++y) {
      out.row(y, rgba.data() + 4 * size_t(y) * size_t(plan.width));
    }
  }
  // The reduction first, once decoding succeeded.
  if (plan.reduced) {
    warnings.insert(warnings.begin() + first, reductionWarning(*header, plan, limits));
  }
  return image;
}

Error outOfMemory(const std::string& name) {
  return runtimeError(name, "ran out of memory while decoding it");
}

}  // namespace

Expected<TextureTexels> decodeTextureImage(const std::string& name, std::string_view bytes,
                                           const ImageLimits& limits) {
  try {
    return decodeTexture(name, bytes, limits);
  } catch (const std::bad_alloc&) {
    return outOfMemory(name);
  }
}

Expected<Image> decodeDataImage(const std::string& name, std::string_view bytes,
                                const ImageLimits& limits) {
  std::vector<std::string> ignored;
  return decodeDataImage(name, bytes, limits, &ignored);
}

Expected<Image> decodeDataImage(const std::string& name, std::string_view bytes,
                                const ImageLimits& limits, std::vector<std::string>* warnings) {
  std::vector<std::string> local;
  try {
    return decodeData(name, bytes, limits, warnings ? *warnings : local);
  } catch (const std::bad_alloc&) {
    return outOfMemory(name);
  }
}

}  // namespace penumbra
