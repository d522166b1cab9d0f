#include "support/image_files.h"

#define STB_IMAGE_WRITE_STATIC
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb_image_write.h>
#include <webp/encode.h>

#include <csetjmp>
#include <cstdio>
// jpeglib.h needs FILE and size_t declared first.
#include <jpeglib.h>
#include <png.h>
#include <zlib.h>

#include <array>
#include <stdexcept>

namespace penumbra::test {

namespace {

void appendToString(void* context, void* data, int size) {
  static_cast<std::string*>(context)->append(static_cast<const char*>(data), size_t(size));
}

void appendBe32(std::string& out, uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) out.push_back(char((v >> s) & 0xff));
}

uint32_t crc32(const std::string& bytes) {
  static const std::array<uint32_t, 256> table = [] {
    std::array<uint32_t, 256> t{};
    for (uint32_t n = 0; n < 256; ++n) {
      uint32_t c = n;
      for (int k = 0; k < 8; ++k) c = c & 1 ? 0xedb88320u ^ (c >> 1) : c >> 1;
      t[n] = c;
    }
    return t;
  }();
  uint32_t c = 0xffffffffu;
  for (unsigned char b : bytes) c = table[(c ^ b) & 0xff] ^ (c >> 8);
  return c ^ 0xffffffffu;
}

void appendChunk(std::string& png, const char* type, const std::string& data) {
  appendBe32(png, uint32_t(data.size()));
  const std::string body = std::string(type, 4) + data;
  png += body;
  appendBe32(png, crc32(body));
}

}  // namespace

Rgba8Image chequer(int width, int height, int cells, const uint8_t a[4], const uint8_t b[4]) {
  Rgba8Image img;
  img.width = width;
  img.height = height;
  img.texels.resize(4 * size_t(width) * size_t(height));
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const bool odd = ((x * cells / width) + (y * cells / height)) % 2 != 0;
      for (int c = 0; c < 4; ++c) {
        img.texels[4 * (size_t(y) * size_t(width) + size_t(x)) + size_t(c)] = odd ? b[c] : a[c];
      }
    }
  }
  return img;
}

std::string pngBytes(const Rgba8Image& image, int channels) {
  std::vector<uint8_t> packed;
  packed.reserve(size_t(image.width) * size_t(image.height) * size_t(channels));
  for (size_t i = 0; i < size_t(image.width) * size_t(image.height); ++i) {
    const uint8_t* t = image.texels.data() + 4 * i;
    switch (channels) {
      case 1:
        packed.push_back(t[0]);
        break;
      case 2:
        packed.push_back(t[0]);
        packed.push_back(t[3]);
        break;
      default:
        for (int c = 0; c < channels; ++c) packed.push_back(t[c]);
    }
  }
  std::string out;
  stbi_write_png_to_func(appendToString, &out, image.width, image.height, channels, packed.data(),
                         image.width * channels);
  return out;
}

std::string jpegBytes(const Rgba8Image& image) {
  std::string out;
  stbi_write_jpg_to_func(appendToString, &out, image.width, image.height, 4, image.texels.data(),
                         100);
  return out;
}

std::string webpBytes(const Rgba8Image& image) {
  uint8_t* data = nullptr;
  const size_t size = WebPEncodeLosslessRGBA(image.texels.data(), image.width, image.height,
                                             image.width * 4, &data);
  if (size == 0) throw std::runtime_error("WebP encoding failed");
  std::string out(reinterpret_cast<const char*>(data), size);
  WebPFree(data);
  return out;
}

std::string png16Bytes(int width, int height, const std::vector<uint16_t>& texels) {
  std::string png("\x89PNG\r\n\x1a\n", 8);
  std::string header;
  appendBe32(header, uint32_t(width));
  appendBe32(header, uint32_t(height));
  header +=
      std::string("\x10\x06\x00\x00\x00", 5);  // 16 bits, RGBA, deflate, filter 0, no interlace
  appendChunk(png, "IHDR", header);
  // The scan lines (filter byte 0, big-endian samples) in stored deflate blocks of a zlib stream.
  std::string raw;
  for (int y = 0; y < height; ++y) {
    raw.push_back('\0');
    for (int x = 0; x < 4 * width; ++x) {
      const uint16_t v = texels[size_t(y) * 4 * size_t(width) + size_t(x)];
      raw.push_back(char(v >> 8));
      raw.push_back(char(v & 0xff));
    }
  }
  std::string z("\x78\x01", 2);
  for (size_t pos = 0; pos < raw.size() || pos == 0;) {
    const size_t n = std::min<size_t>(65535, raw.size() - pos);
    const bool last = pos + n >= raw.size();
    z.push_back(last ? '\x01' : '\x00');
    z.push_back(char(n & 0xff));
    z.push_back(char(n >> 8));
    z.push_back(char(~n & 0xff));
    z.push_back(char((~n >> 8) & 0xff));
    z += raw.substr(pos, n);
    pos += n;
    if (last) break;
  }
  uint32_t s1 = 1, s2 = 0;
  for (unsigned char c : raw) {
    s1 = (s1 + c) % 65521;
    s2 = (s2 + s1) % 65521;
  }
  appendBe32(z, (s2 << 16) | s1);
  appendChunk(png, "IDAT", z);
  appendChunk(png, "IEND", "");
  return png;
}

namespace {

void appendToPng(png_structp png, png_bytep data, size_t size) {
  static_cast<std::string*>(png_get_io_ptr(png))->append(reinterpret_cast<const char*>(data), size);
}

// The scan lines as PNG stores them: samples packed big-endian, low depths several to a byte.
std::vector<std::vector<uint8_t>> packedRows(const PngSpec& spec) {
  const int channels = spec.colour_type == 0 || spec.colour_type == 3 ? 1
                       : spec.colour_type == 4                        ? 2
                       : spec.colour_type == 2                        ? 3
                                                                      : 4;
  const size_t row_samples = size_t(spec.width) * size_t(channels);
  if (spec.samples.size() != row_samples * size_t(spec.height)) {
    throw std::runtime_error("encodePng: wrong number of samples");
  }
  std::vector<std::vector<uint8_t>> rows(size_t(spec.height));
  for (size_t y = 0; y < rows.size(); ++y) {
    std::vector<uint8_t>& row = rows[y];
    row.assign((row_samples * size_t(spec.bit_depth) + 7) / 8, 0);
    for (size_t i = 0; i < row_samples; ++i) {
      const uint16_t v = spec.samples[y * row_samples + i];
      if (spec.bit_depth == 16) {
        row[2 * i] = uint8_t(v >> 8);
        row[2 * i + 1] = uint8_t(v & 0xff);
      } else {
        const size_t bit = i * size_t(spec.bit_depth);
        row[bit / 8] |= uint8_t(v << (8 - spec.bit_depth - bit % 8));
      }
    }
  }
  return rows;
}

void pngQuiet(png_structp, png_const_charp) {}

[[noreturn]] void pngWriteError(png_structp, png_const_charp message) {
  throw std::runtime_error(std::string("encodePng: ") + message);
}

}  // namespace

std::string encodePng(const PngSpec& spec) {
  std::vector<std::vector<uint8_t>> rows = packedRows(spec);
  std::vector<png_bytep> row_pointers;
  for (std::vector<uint8_t>& r : rows) row_pointers.push_back(r.data());
  std::string out;
  // The error handler throws (libpng and zlib are built with unwind tables on this platform); a
  // test that fails here has a wrong spec.
  png_structp png =
      png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, pngWriteError, pngQuiet);
  png_infop info = png_create_info_struct(png);
  png_set_write_fn(png, &out, appendToPng, nullptr);
  png_set_IHDR(png, info, uint32_t(spec.width), uint32_t(spec.height), spec.bit_depth,
               spec.colour_type, spec.interlaced ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  std::vector<png_color> palette;
  for (size_t i = 0; i + 2 < spec.palette.size(); i += 3) {
    palette.push_back({spec.palette[i], spec.palette[i + 1], spec.palette[i + 2]});
  }
  if (!palette.empty()) png_set_PLTE(png, info, palette.data(), int(palette.size()));
  if (!spec.palette_alpha.empty()) {
    png_set_tRNS(png, info, spec.palette_alpha.data(), int(spec.palette_alpha.size()), nullptr);
  }
  if (spec.unchecked_indices) {
    png_set_check_for_invalid_index(png, 1);
    png_set_benign_errors(png, 1);
  }
  png_write_info(png, info);
  if (spec.interlaced) png_set_interlace_handling(png);
  png_write_image(png, row_pointers.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return out;
}

std::string encodeJpeg(const Rgba8Image& image, int quality, bool progressive, bool grey) {
  jpeg_compress_struct cinfo;
  jpeg_error_mgr err;
  cinfo.err = jpeg_std_error(&err);
  jpeg_create_compress(&cinfo);
  unsigned char* buffer = nullptr;
  unsigned long size = 0;
  jpeg_mem_dest(&cinfo, &buffer, &size);
  cinfo.image_width = JDIMENSION(image.width);
  cinfo.image_height = JDIMENSION(image.height);
  cinfo.input_components = grey ? 1 : 3;
  cinfo.in_color_space = grey ? JCS_GRAYSCALE : JCS_RGB;
  jpeg_set_defaults(&cinfo);
  jpeg_set_quality(&cinfo, quality, TRUE);
  if (progressive) jpeg_simple_progression(&cinfo);
  jpeg_start_compress(&cinfo, TRUE);
  std::vector<uint8_t> row(size_t(image.width) * 3);
  while (cinfo.next_scanline < cinfo.image_height) {
    const uint8_t* in = image.texels.data() + 4 * size_t(cinfo.next_scanline) * size_t(image.width);
    for (size_t x = 0; x < size_t(image.width); ++x) {
      for (size_t c = 0; c < (grey ? 1u : 3u); ++c) row[(grey ? 1 : 3) * x + c] = in[4 * x + c];
    }
    JSAMPROW r = row.data();
    jpeg_write_scanlines(&cinfo, &r, 1);
  }
  jpeg_finish_compress(&cinfo);
  jpeg_destroy_compress(&cinfo);
  std::string out(reinterpret_cast<const char*>(buffer), size);
  std::free(buffer);
  return out;
}

std::string webpLossyBytes(const Rgba8Image& image, float quality) {
  uint8_t* data = nullptr;
  const size_t size = WebPEncodeRGBA(image.texels.data(), image.width, image.height,
                                     image.width * 4, quality, &data);
  if (size == 0) throw std::runtime_error("WebP encoding failed");
  std::string out(reinterpret_cast<const char*>(data), size);
  WebPFree(data);
  return out;
}

namespace {

// A zlib stream of `n` zero bytes (see zeroPng).
std::string zeroZlib(uint64_t n) {
  constexpr size_t kChunk = size_t(1) << 20;
  const std::vector<unsigned char> zeros(kChunk, 0);
  z_stream z{};
  deflateInit(&z, 9);
  auto deflateZeros = [&](size_t len, int flush) {
    std::string out;
    z.next_in = const_cast<unsigned char*>(zeros.data());
    z.avail_in = uInt(len);
    unsigned char buffer[1 << 16];
    do {
      z.next_out = buffer;
      z.avail_out = sizeof buffer;
      deflate(&z, flush);
      out.append(reinterpret_cast<const char*>(buffer), sizeof buffer - z.avail_out);
    } while (z.avail_out == 0);
    return out;
  };
  std::string out, previous, repeated;
  uint64_t left = n;
  while (left > kChunk) {
    // After the first chunks the window holds only zeros: every 1 MiB encodes the same.
    const std::string block = repeated.empty() ? deflateZeros(kChunk, Z_SYNC_FLUSH) : repeated;
    if (repeated.empty() && block == previous) repeated = block;
    previous = block;
    out += block;
    left -= kChunk;
  }
  out += deflateZeros(size_t(left), Z_FINISH);
  deflateEnd(&z);
  // zlib's trailer counts only what it was given: the Adler-32 of n zeros is (n mod 65521, 1).
  const uint32_t adler = uint32_t(n % 65521) << 16 | 1u;
  for (int k = 0; k < 4; ++k) out[out.size() - 4 + size_t(k)] = char(adler >> (24 - 8 * k));
  return out;
}

void appendPngChunk(std::string& png, const char* type, const std::string& data) {
  appendBe32(png, uint32_t(data.size()));
  const std::string body = std::string(type, 4) + data;
  png += body;
  appendBe32(png,
             uint32_t(::crc32(0, reinterpret_cast<const Bytef*>(body.data()), uInt(body.size()))));
}

}  // namespace

std::string zeroPng(int width, int height, int colour_type, int bit_depth) {
  const int channels = colour_type == 0 || colour_type == 3 ? 1
                       : colour_type == 4                   ? 2
                       : colour_type == 2                   ? 3
                                                            : 4;
  const uint64_t row = 1 + (uint64_t(width) * uint64_t(channels) * uint64_t(bit_depth) + 7) / 8;
  std::string png("\x89PNG\r\n\x1a\n", 8);
  std::string header;
  appendBe32(header, uint32_t(width));
  appendBe32(header, uint32_t(height));
  header += {char(bit_depth), char(colour_type), 0, 0, 0};
  appendPngChunk(png, "IHDR", header);
  if (colour_type == 3) appendPngChunk(png, "PLTE", std::string(3, '\0'));
  const std::string z = zeroZlib(row * uint64_t(height));
  for (size_t at = 0; at < z.size(); at += size_t(8) << 20) {
    appendPngChunk(png, "IDAT", z.substr(at, size_t(8) << 20));
  }
  appendPngChunk(png, "IEND", "");
  return png;
}

}  // namespace penumbra::test
