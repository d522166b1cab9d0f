// Image files:
//   .exr  OpenEXR 3 (scan lines, 32-bit FLOAT R, G, B, ZIP compression), lossless.
//   .hdr  Radiance RGBE (G. Ward, "Real pixels", Graphics Gems II, 1991) via stb_image(_write):
//         an 8-bit mantissa per channel sharing one exponent, so about 1% relative precision.
//   .pfm  Portable Float Map, by hand: "PF" (RGB) or "Pf" (grey), "width height", a scale whose
//         sign gives the byte order (negative: little endian), then float32 rows from the
//         bottom of the image to the top. Lossless.
//   .png  8-bit sRGB (IEC 61966-2-1) after tone mapping, written by stb_image_write and read
//         back by libpng (image_decode.h).
// Writes go through writeAtomically; no exception escapes this file.
#include "penumbra/io/image_io.h"

#include "penumbra/core/parallel.h"

#include "penumbra/core/memory.h"

#include "penumbra/core/file_util.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfCompression.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>

// The stb implementations are private to this file: image_decode.cpp has its own for TGA. stb_image
// reads Radiance HDR only here.
#define STB_IMAGE_STATIC
#define STB_IMAGE_WRITE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STBI_ONLY_HDR
#define STBI_NO_STDIO
#include <stb_image.h>
#include <stb_image_write.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <string_view>
#include <vector>

namespace penumbra {

namespace {

static_assert(sizeof(glm::vec3) == 3 * sizeof(float), "Image pixels must be 3 packed floats");

// Larger images are refused when reading, so a corrupt header cannot ask for terabytes.
constexpr int64_t kMaxReadPixels = int64_t(1) << 28;

const char* const kSupportedList = "use .exr, .hdr, .pfm or .png";

Error unsupportedFormat(const std::string& path) {
  const std::string ext = extensionOf(path);
  return inputError(path, "",
                    ext.empty()
                        ? std::string("no image file extension (") + kSupportedList + ")"
                        : "unsupported image format '" + ext + "' (" + kSupportedList + ")");
}

// Existence checks before handing a path to a library, for one wording of the common failures.
Status checkReadable(const std::string& path) {
  return checkInputFile(path);
}

Status checkWritable(const std::string& path, const Image& image) {
  if (image.width <= 0 || image.height <= 0) {
    return runtimeError(path, "cannot write an empty image (" + std::to_string(image.width) + "x" +
                                  std::to_string(image.height) + ")");
  }
  if (int64_t(image.width) * int64_t(image.height) * 4 > std::numeric_limits<int>::max()) {
    return runtimeError(path, "image too large to write (" + std::to_string(image.width) + "x" +
                                  std::to_string(image.height) + ")");
  }
  if (image.pixels.size() != size_t(image.width) * size_t(image.height)) {
    return runtimeError(path, "image of " + std::to_string(image.width) + "x" +
                                  std::to_string(image.height) + " has " +
                                  std::to_string(image.pixels.size()) + " pixels");
  }
  return {};
}

// ---- OpenEXR -------------------------------------------------------------------------------

Status writeExr(const std::string& path, const std::string& tmp, const Image& image) {
  try {
    Imf::Header header(image.width, image.height);
    header.compression() = Imf::ZIP_COMPRESSION;
    for (const char* name : {"R", "G", "B"}) {
      header.channels().insert(name, Imf::Channel(Imf::FLOAT));
    }
    const size_t x_stride = sizeof(glm::vec3);
    const size_t y_stride = x_stride * size_t(image.width);
    // OpenEXR only reads through the pointer when writing; its Slice takes char*.
    char* base = const_cast<char*>(reinterpret_cast<const char*>(image.pixels.data()));
    Imf::FrameBuffer frame;
    for (int c = 0; c < 3; ++c) {
      const char* name = c == 0 ? "R" : c == 1 ? "G" : "B";
      frame.insert(name, Imf::Slice(Imf::FLOAT, base + c * sizeof(float), x_stride, y_stride));
    }
    Imf::OutputFile file(tmp.c_str(), header);
    file.setFrameBuffer(frame);
    file.writePixels(image.height);
  } catch (const std::exception& e) {
    // OpenEXR names the file it opened; name the one the user asked for.
    std::string what = e.what();
    for (size_t at = what.find(tmp); at != std::string::npos;
         at = what.find(tmp, at + path.size())) {
      what.replace(at, tmp.size(), path);
    }
    return runtimeError(path, "cannot write OpenEXR file: " + what);
  } catch (...) {
    return runtimeError(path, "cannot write OpenEXR file");
  }
  return {};
}

// Refuses to decode a w x h image (12 bytes a pixel, and as much again for a decoder's copy)
// that would not fit in memory, naming the file.
Status checkDecodeMemory(const std::string& path, int64_t w, int64_t h) {
  if (Status m =
          checkMemory(uint64_t(w) * uint64_t(h) * 24, fmt::format("reading a {} x {} image", w, h));
      !m.ok()) {
    return inputError(path, "", m.error().message);
  }
  return {};
}

// Walks the header(s) of an OpenEXR file (OpenEXR file layout: the magic number 20000630, a
// version field whose bit 12 marks a multi-part file, then per part a list of attributes, each a
// name, a type name, a 32-bit size and that many bytes, ended by an empty name; a multi-part
// file ends its list of headers with one more empty name). OpenEXR trusts the sizes it reads: an
// attribute claiming a gigabyte in a 500-byte file keeps its reader busy for many seconds. So
// each size is checked against the bytes that follow before OpenEXR opens the file.
Status checkExrHeaders(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  in.seekg(0, std::ios::end);
  const int64_t size = in.tellg();
  in.seekg(0);
  if (!in || size < 8) return inputError(path, "header", "not an OpenEXR file (too short)");
  unsigned char start[8];
  in.read(reinterpret_cast<char*>(start), 8);
  if (!(start[0] == 0x76 && start[1] == 0x2f && start[2] == 0x31 && start[3] == 0x01)) {
    return inputError(path, "header", "not an OpenEXR file (no magic number)");
  }
  const bool multipart = (start[5] & 0x10) != 0;  // bit 12 of the little-endian version field
  const size_t max_name = (start[5] & 0x04) ? 255 : 31;  // bit 10: long names
  int64_t at = 8;
  // A name or type name: printable bytes up to a NUL, at most max_name of them.
  auto readName = [&](std::string* name) -> Status {
    name->clear();
    for (;;) {
      const int c = in.get();
      if (c == EOF) return inputError(path, fmt::format("byte {}", at), "the header ends early");
      ++at;
      if (c == 0) return {};
      if (name->size() >= max_name) {
        return inputError(path, fmt::format("byte {}", at),
                          fmt::format("an attribute name longer than {} bytes", max_name));
      }
      name->push_back(static_cast<char>(c));
    }
  };
  std::string name, type;
  int parts = 0, attributes = 0;  // headers ended, attributes in the current one
  for (;;) {
    PENUMBRA_TRY(readName(&name));
    if (name.empty()) {
      if (attributes == 0) {
        if (multipart && parts > 0) return {};  // the empty name that ends the list of headers
        return inputError(path, fmt::format("byte {}", at), "an empty header");
      }
      ++parts;
      attributes = 0;
      if (!multipart) return {};
      continue;
    }
    ++attributes;
    PENUMBRA_TRY(readName(&type));
    if (type.empty()) {
      return inputError(path, fmt::format("attribute '{}'", name), "an empty type name");
    }
    unsigned char b[4];
    if (!in.read(reinterpret_cast<char*>(b), 4)) {
      return inputError(path, fmt::format("attribute '{}'", name), "the header ends early");
    }
    at += 4;
    const int32_t bytes =
        int32_t(uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24);
    if (bytes < 0 || bytes > size - at) {
      return inputError(path, fmt::format("attribute '{}'", name),
                        fmt::format("its size {} runs past the end of the file ({} bytes left)",
                                    bytes, size - at));
    }
    at += bytes;
    in.seekg(at);
  }
}

Expected<Image> readExr(const std::string& path) {
  PENUMBRA_TRY(checkReadable(path));
  PENUMBRA_TRY(checkExrHeaders(path));
  try {
    Imf::InputFile file(path.c_str());
    const Imf::Header& header = file.header();
    const Imath::Box2i window = header.dataWindow();
    const int64_t w = int64_t(window.max.x) - int64_t(window.min.x) + 1;
    const int64_t h = int64_t(window.max.y) - int64_t(window.min.y) + 1;
    if (w <= 0 || h <= 0) return inputError(path, "header", "empty data window");
    if (w * h > kMaxReadPixels) {
      return inputError(path, "header",
                        "image too large (" + std::to_string(w) + "x" + std::to_string(h) + ")");
    }
    // R, G, B (missing ones read as 0), or a luminance-only Y image copied to all three.
    const Imf::ChannelList& channels = header.channels();
    const bool has_rgb =
        channels.findChannel("R") || channels.findChannel("G") || channels.findChannel("B");
    const bool has_y = channels.findChannel("Y") != nullptr;
    if (!has_rgb && !has_y) return inputError(path, "header", "no R, G, B or Y channel");

    PENUMBRA_TRY(checkDecodeMemory(path, w, h));
    Image image(static_cast<int>(w), static_cast<int>(h));
    char* base = reinterpret_cast<char*>(image.pixels.data());
    const size_t x_stride = sizeof(glm::vec3);
    const size_t y_stride = x_stride * size_t(w);
    Imf::FrameBuffer frame;
    for (int c = 0; c < (has_rgb ? 3 : 1); ++c) {
      const char* name = has_rgb ? (c == 0 ? "R" : c == 1 ? "G" : "B") : "Y";
      // Slice::Make offsets the base so that data window pixel (min.x, min.y) lands at index 0.
      frame.insert(
          name, Imf::Slice::Make(Imf::FLOAT, base + c * sizeof(float), window, x_stride, y_stride));
    }
    file.setFrameBuffer(frame);
    file.readPixels(window.min.y, window.max.y);
    if (!has_rgb) {
      for (glm::vec3& p : image.pixels) p = glm::vec3(p.x);
    }
    return image;
  } catch (const std::exception& e) {
    return inputError(path, "", std::string("cannot read OpenEXR file: ") + e.what());
  } catch (...) {
    return inputError(path, "", "cannot read OpenEXR file");
  }
}

// ---- Radiance HDR and PNG (stb) ------------------------------------------------------------

// stb's file writers do not check fwrite: encode into memory and write with every call checked.
void appendToString(void* context, void* data, int size) {
  static_cast<std::string*>(context)->append(static_cast<const char*>(data), size_t(size));
}

Status writeHdr(const std::string& path, const std::string& tmp, const Image& image) {
  // RGBE holds non-negative values up to about 2^127 (the exponent byte is e + 128); stb would
  // wrap the exponent of larger values, and NaN has no encoding.
  constexpr float kMaxRgbe = 1e38f;
  std::vector<float> data(image.pixels.size() * 3);
  for (size_t i = 0; i < image.pixels.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      const float v = image.pixels[i][c];
      data[3 * i + size_t(c)] = v > 0.0f ? std::min(v, kMaxRgbe) : 0.0f;  // NaN -> 0
    }
  }
  std::string bytes;
  if (!stbi_write_hdr_to_func(appendToString, &bytes, image.width, image.height, 3, data.data())) {
    return runtimeError(path, "cannot encode a Radiance HDR file");
  }
  return writeBytesTo(path, tmp, bytes);
}

Status writePng(const std::string& path, const std::string& tmp, const Image& image,
                const ToneMapSettings& tonemap) {
  const std::vector<uint8_t> data = displayBytes(image, tonemap);
  std::string bytes;
  if (!stbi_write_png_to_func(appendToString, &bytes, image.width, image.height, 3, data.data(),
                              image.width * 3)) {
    return runtimeError(path, "cannot encode a PNG file");
  }
  return writeBytesTo(path, tmp, bytes);
}

// IEC 61966-2-1 inverse transfer function.
float decodeSrgb(double encoded) {
  return float(encoded <= 0.04045 ? encoded / 12.92 : std::pow((encoded + 0.055) / 1.055, 2.4));
}

Expected<std::string> readWholeFile(const std::string& path) {
  Expected<std::string> bytes = readFile(path);
  if (!bytes) return bytes.error();
  if (bytes->size() > size_t(std::numeric_limits<int>::max())) {
    return inputError(path, "", "file too large");
  }
  return bytes;
}

struct StbFree {
  void operator()(void* p) const { stbi_image_free(p); }
};

// stb_image 2.27 loops forever on a zero run count in run-length encoded RGBE data, which a
// truncated file produces (it reads 0 past the end). So first walk the scan lines the way
// stbi__hdr_load does, and report truncated or corrupt data as an error.
Status checkRgbeData(const std::string& path, std::string_view bytes) {
  // The header ends with an empty line; the resolution line "-Y height +X width" follows.
  size_t pos = bytes.find("\n\n");
  if (pos == std::string_view::npos) return inputError(path, "header", "no end of header");
  pos += 2;
  const size_t eol = bytes.find('\n', pos);
  if (eol == std::string_view::npos) return inputError(path, "header", "no resolution line");
  const std::string resolution(bytes.substr(pos, std::min<size_t>(eol - pos, 64)));
  int width = 0, height = 0;
  if (std::sscanf(resolution.c_str(), "-Y %d +X %d", &height, &width) != 2 || width <= 0 ||
      height <= 0) {
    return inputError(
        path, "header",
        "unsupported resolution line '" + resolution + "' (use '-Y height +X width')");
  }
  if (int64_t(width) * int64_t(height) > kMaxReadPixels) {
    return inputError(path, "header", "image too large (" + resolution + ")");
  }
  pos = eol + 1;
  const size_t size = bytes.size();
  const auto byte = [&](size_t i) { return int(uint8_t(bytes[i])); };
  auto truncated = [&](int y) {
    return inputError(path, "scan line " + std::to_string(y),
                      "truncated pixel data (" + std::to_string(height) + " scan lines expected)");
  };
  const size_t flat_size = size_t(width) * size_t(height) * 4;
  if (width < 8 || width >= 32768) {  // too narrow or wide for run-length encoding: flat RGBE
    return size - pos >= flat_size ? Status() : truncated(0);
  }
  for (int y = 0; y < height; ++y) {
    if (size - pos < 4) return truncated(y);
    if (byte(pos) != 2 || byte(pos + 1) != 2 || (byte(pos + 2) & 0x80) != 0) {
      // Not run-length encoded; stb reads the whole image flat from the first scan line.
      if (y > 0) {
        return inputError(path, "scan line " + std::to_string(y),
                          "flat scan line after run-length encoded ones (not supported)");
      }
      return size - pos >= flat_size ? Status() : truncated(0);
    }
    if (((byte(pos + 2) << 8) | byte(pos + 3)) != width) {
      return inputError(path, "scan line " + std::to_string(y), "wrong scan line length");
    }
    pos += 4;
    for (int component = 0; component < 4; ++component) {
      for (int x = 0; x < width;) {
        if (pos >= size) return truncated(y);
        int count = byte(pos++);
        const bool run = count > 128;
        if (run) count -= 128;
        if (count == 0 || count > width - x) {
          return inputError(path, "scan line " + std::to_string(y), "bad run length");
        }
        const size_t payload = run ? 1 : size_t(count);
        if (size - pos < payload) return truncated(y);
        pos += payload;
        x += count;
      }
    }
  }
  return {};
}

Expected<Image> readHdr(const std::string& path) {
  Expected<std::string> bytes = readWholeFile(path);
  if (!bytes) return bytes.error();
  const auto* data = reinterpret_cast<const stbi_uc*>(bytes->data());
  const int len = int(bytes->size());
  // stbi_loadf would also accept a PNG and convert it with a gamma curve; insist on RGBE.
  if (!stbi_is_hdr_from_memory(data, len)) {
    return inputError(path, "", "not a Radiance HDR file (no '#?RADIANCE' or '#?RGBE' header)");
  }
  PENUMBRA_TRY(checkRgbeData(path, *bytes));
  int w = 0, h = 0, n = 0;
  if (stbi_info_from_memory(data, len, &w, &h, &n)) {
    if (int64_t(w) * int64_t(h) > kMaxReadPixels) return inputError(path, "", "image too large");
    PENUMBRA_TRY(checkDecodeMemory(path, w, h));
  }
  std::unique_ptr<float, StbFree> pixels(stbi_loadf_from_memory(data, len, &w, &h, &n, 3));
  if (!pixels) {
    return inputError(path, "",
                      std::string("malformed Radiance HDR file: ") + stbi_failure_reason());
  }
  if (int64_t(w) * int64_t(h) > kMaxReadPixels) return inputError(path, "", "image too large");
  Image image(w, h);
  for (size_t i = 0; i < image.pixels.size(); ++i) {
    const float* p = pixels.get() + 3 * i;
    image.pixels[i] = glm::vec3(p[0], p[1], p[2]);
  }
  return image;
}

// A PNG read back (a render, a reference): libpng through image_decode.h, never reduced, decoded
// from sRGB to linear.
Expected<Image> readPng(const std::string& path) {
  Expected<std::string> bytes = readWholeFile(path);
  if (!bytes) return bytes.error();
  // Not a JPEG or Radiance file that happens to be named .png.
  if (imageFormatOf(path, *bytes) != ImageFormat::kPng) {
    return inputError(path, "", "not a PNG file (no PNG signature)");
  }
  Expected<ImageHeader> header = readImageHeader(path, *bytes);
  if (!header) return header.error();
  ImageLimits limits;
  limits.max_size = std::numeric_limits<int>::max();
  Expected<Image> image = decodeDataImage(path, *bytes, limits);
  if (!image) return image.error();
  // The stored codes, through a table of the transfer function.
  const int max_code = header->sixteen_bit ? 65535 : 255;
  std::vector<float> linear(size_t(max_code) + 1);
  for (int k = 0; k <= max_code; ++k) linear[size_t(k)] = decodeSrgb(double(k) / max_code);
  parallelRange(image->pixels.size(), 4096, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      for (int c = 0; c < 3; ++c) {
        float& v = image->pixels[i][c];
        v = linear[size_t(std::lround(double(v) * max_code))];
      }
    }
  });
  return image;
}

// ---- Portable Float Map ---------------------------------------------------------------------

void appendFloatLe(std::string& out, float v) {
  const uint32_t bits = std::bit_cast<uint32_t>(v);
  for (int b = 0; b < 4; ++b) out.push_back(char((bits >> (8 * b)) & 0xffu));
}

float floatAt(const char* p, bool little_endian) {
  uint32_t bits = 0;
  for (int b = 0; b < 4; ++b) {
    const uint32_t byte = uint8_t(p[b]);
    bits |= little_endian ? byte << (8 * b) : byte << (8 * (3 - b));
  }
  return std::bit_cast<float>(bits);
}

Status writePfm(const std::string& path, const std::string& tmp, const Image& image) {
  std::string out =
      "PF\n" + std::to_string(image.width) + " " + std::to_string(image.height) + "\n-1.0\n";
  out.reserve(out.size() + image.pixels.size() * 12);
  for (int y = image.height - 1; y >= 0; --y) {  // PFM rows run bottom to top
    for (int x = 0; x < image.width; ++x) {
      const glm::vec3& p = image.at(x, y);
      appendFloatLe(out, p.x);
      appendFloatLe(out, p.y);
      appendFloatLe(out, p.z);
    }
  }
  return writeBytesTo(path, tmp, out);
}

// Splits the PFM header: three whitespace-separated tokens and the offset of the pixel data,
// which follows the scale after exactly one whitespace character.
struct PfmHeaderReader {
  std::string_view text;
  size_t pos = 0;

  static bool isSpace(char c) { return c == ' ' || c == '\n' || c == '\r' || c == '\t'; }
  std::string_view next() {
    while (pos < text.size() && isSpace(text[pos])) ++pos;
    const size_t start = pos;
    while (pos < text.size() && !isSpace(text[pos]) && pos - start < 64) ++pos;
    return text.substr(start, pos - start);
  }
};

bool parseDimension(std::string_view token, int& out) {
  if (token.empty() || token.size() > 10) return false;
  int64_t v = 0;
  for (char c : token) {
    if (c < '0' || c > '9') return false;
    v = v * 10 + (c - '0');
  }
  if (v <= 0 || v > std::numeric_limits<int>::max()) return false;
  out = int(v);
  return true;
}

Expected<Image> readPfm(const std::string& path) {
  Expected<std::string> bytes = readFile(path);
  if (!bytes) return bytes.error();
  const std::string& s = *bytes;
  PfmHeaderReader header{s};
  const std::string_view magic = header.next();
  if (magic != "PF" && magic != "Pf") {
    return inputError(path, "header", "not a PFM file (expected 'PF' or 'Pf')");
  }
  const int channels = magic == "PF" ? 3 : 1;
  int w = 0, h = 0;
  const std::string_view w_token = header.next();
  const std::string_view h_token = header.next();
  if (!parseDimension(w_token, w) || !parseDimension(h_token, h)) {
    return inputError(path, "header",
                      "bad image size '" + std::string(w_token) + " " + std::string(h_token) + "'");
  }
  const std::string scale_token(header.next());
  char* end = nullptr;
  const double scale = std::strtod(scale_token.c_str(), &end);
  if (scale_token.empty() || end != scale_token.c_str() + scale_token.size() ||
      !std::isfinite(scale) || scale == 0.0) {
    return inputError(
        path, "header",
        "bad scale '" + scale_token + "' (a non-zero number, negative for little endian)");
  }
  // The magnitude of the scale is not applied: writers use +-1, as the format's common readers
  // (pfstools, HDRShop) assume for radiance.
  const bool little_endian = scale < 0.0;
  if (header.pos >= s.size() || !PfmHeaderReader::isSpace(s[header.pos])) {
    return inputError(path, "header", "truncated header");
  }
  const size_t data_offset = header.pos + 1;
  if (int64_t(w) * int64_t(h) > kMaxReadPixels) {
    return inputError(path, "header",
                      "image too large (" + std::to_string(w) + "x" + std::to_string(h) + ")");
  }
  const size_t needed = size_t(w) * size_t(h) * size_t(channels) * sizeof(float);
  const size_t available = s.size() - data_offset;
  if (available < needed) {
    return inputError(path, "pixel data",
                      "truncated: " + std::to_string(w) + "x" + std::to_string(h) + " needs " +
                          std::to_string(needed) + " bytes, found " + std::to_string(available));
  }
  Image image(w, h);
  const char* p = s.data() + data_offset;
  for (int y = h - 1; y >= 0; --y) {
    for (int x = 0; x < w; ++x) {
      glm::vec3& out = image.at(x, y);
      if (channels == 3) {
        out = glm::vec3(floatAt(p, little_endian), floatAt(p + 4, little_endian),
                        floatAt(p + 8, little_endian));
      } else {
        out = glm::vec3(floatAt(p, little_endian));
      }
      p += channels * sizeof(float);
    }
  }
  return image;
}

}  // namespace

std::vector<uint8_t> displayBytes(const Image& linear, const ToneMapSettings& tonemap) {
  const Image display = toneMap(linear, tonemap);
  std::vector<uint8_t> data(display.pixels.size() * 3);
  parallelRange(display.pixels.size(), 4096, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      for (int c = 0; c < 3; ++c) data[3 * i + size_t(c)] = encodeSrgb8(display.pixels[i][c]);
    }
  });
  return data;
}

Expected<std::string> encodePng8(int width, int height, std::span<const uint8_t> pixels,
                                 int channels) {
  if (width < 1 || height < 1 || (channels != 3 && channels != 4) ||
      pixels.size() != size_t(width) * size_t(height) * size_t(channels)) {
    return runtimeError("", "cannot encode a PNG: the pixels do not fill the image");
  }
  std::string bytes;
  if (!stbi_write_png_to_func(appendToString, &bytes, width, height, channels, pixels.data(),
                              width * channels)) {
    return runtimeError("", "cannot encode a PNG");
  }
  return bytes;
}

Status writePng8(const std::string& path, int width, int height, std::span<const uint8_t> rgb,
                 int channels) {
  if (extensionOf(path) != ".png") return unsupportedFormat(path);
  Expected<std::string> bytes = encodePng8(width, height, rgb, channels);
  if (!bytes) return runtimeError(path, bytes.error().message);
  return writeAtomically(path,
                         [&](const std::string& tmp) { return writeBytesTo(path, tmp, *bytes); });
}

bool isSupportedImageExtension(const std::string& path) {
  const std::string ext = extensionOf(path);
  return ext == ".exr" || ext == ".hdr" || ext == ".pfm" || ext == ".png";
}

Status writeImage(const std::string& path, const Image& linear, const ToneMapSettings& tonemap) {
  if (!isSupportedImageExtension(path)) return unsupportedFormat(path);
  PENUMBRA_TRY(checkWritable(path, linear));
  const std::string ext = extensionOf(path);
  return writeAtomically(path, [&](const std::string& tmp) -> Status {
    try {
      if (ext == ".exr") return writeExr(path, tmp, linear);
      if (ext == ".hdr") return writeHdr(path, tmp, linear);
      if (ext == ".pfm") return writePfm(path, tmp, linear);
      return writePng(path, tmp, linear, tonemap);
    } catch (const std::exception& e) {  // std::bad_alloc and the like
      return runtimeError(path, std::string("cannot write: ") + e.what());
    }
  });
}

Expected<Image> readImage(const std::string& path) {
  if (!isSupportedImageExtension(path)) return unsupportedFormat(path);
  try {
    const std::string ext = extensionOf(path);
    if (ext == ".exr") return readExr(path);
    if (ext == ".hdr") return readHdr(path);
    if (ext == ".pfm") return readPfm(path);
    return readPng(path);
  } catch (const std::exception& e) {  // std::bad_alloc and the like
    return runtimeError(path, std::string("cannot read: ") + e.what());
  }
}

Expected<Image> readImageData(const std::string& path) {
  return readImageData(path, {}, nullptr);
}

Expected<Image> readImageData(const std::string& path, const ImageLimits& limits,
                              std::vector<std::string>* warnings) {
  const std::string ext = extensionOf(path);
  if (ext == ".exr" || ext == ".hdr" || ext == ".pfm") return readImage(path);
  Expected<std::string> bytes = readFile(path);
  if (!bytes) return bytes.error();
  return decodeDataImage(path, *bytes, limits, warnings);
}

}  // namespace penumbra
