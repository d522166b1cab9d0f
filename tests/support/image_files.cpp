#include "support/image_files.h"

#define STB_IMAGE_WRITE_STATIC
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb_image_write.h>
#include <webp/encode.h>

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

}  // namespace penumbra::test
