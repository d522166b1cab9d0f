// Texture decoding (io/image_decode.h) against hostile and unusual files: decode bombs refused
// from their headers or reduced within their plans (the memory a decode takes is measured), the
// JPEG scan budget counted, palettes of every depth and indices past them, top-down and 16-bit
// BMPs, TGA kinds, one-colour WebPs, JPEG and WebP normal maps, CRCs, and each message's words.
// Every image is made here, with libpng, libjpeg-turbo and libwebp or by hand.
#include "penumbra/io/image_decode.h"

#include "penumbra/core/memory.h"
#include "penumbra/io/image_io.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/scene/texture.h"
#include "support/image_files.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <zlib.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cstdint>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

namespace penumbra {
namespace {

using test::Rgba8Image;

// ---- files made by hand ------------------------------------------------------------------------

void putLe(std::string& out, uint32_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) out.push_back(char((v >> (8 * i)) & 0xff));
}
void putBe(std::string& out, uint32_t v, int bytes) {
  for (int i = bytes - 1; i >= 0; --i) out.push_back(char((v >> (8 * i)) & 0xff));
}

// A BMP with a 40-byte BITMAPINFOHEADER (or 108 with masks). `value(x, y)`: the pixel at image
// row y (0 at the top) as stored: a palette index, or a 16- or 32-bit word, or 0xRRGGBB for 24.
struct BmpSpec {
  int width = 1, height = 1, bpp = 24;
  bool top_down = false;
  uint32_t compression = 0;
  std::vector<uint32_t> palette;  // 0xRRGGBB
  std::array<uint32_t, 4> masks{};
  bool v4_header = false;  // BITMAPV4HEADER with the masks inside
  std::function<uint32_t(int, int)> value;
};

std::string bmpFile(const BmpSpec& s) {
  const uint32_t header = s.v4_header ? 108 : 40;
  const bool masks_after = !s.v4_header && s.compression == 3;
  const uint32_t offset = 14 + header + (masks_after ? 12 : 0) + 4 * uint32_t(s.palette.size());
  const size_t stride = (size_t(s.width) * size_t(s.bpp) + 31) / 32 * 4;
  std::string out = "BM";
  putLe(out, offset + uint32_t(stride) * uint32_t(s.height), 4);
  putLe(out, 0, 4);
  putLe(out, offset, 4);
  putLe(out, header, 4);
  putLe(out, uint32_t(s.width), 4);
  putLe(out, uint32_t(s.top_down ? -s.height : s.height), 4);
  putLe(out, 1, 2);
  putLe(out, uint32_t(s.bpp), 2);
  putLe(out, s.compression, 4);
  putLe(out, uint32_t(stride) * uint32_t(s.height), 4);
  putLe(out, 2835, 4);
  putLe(out, 2835, 4);
  putLe(out, uint32_t(s.palette.size()), 4);
  putLe(out, 0, 4);
  if (s.v4_header) {
    for (uint32_t m : s.masks) putLe(out, m, 4);
    out.append(108 - 56, '\0');
  } else if (masks_after) {
    for (int c = 0; c < 3; ++c) putLe(out, s.masks[size_t(c)], 4);
  }
  for (uint32_t c : s.palette) putLe(out, c, 4);  // B, G, R, 0
  for (int r = 0; r < s.height; ++r) {
    const int y = s.top_down ? r : s.height - 1 - r;
    std::string row(stride, '\0');
    for (int x = 0; x < s.width; ++x) {
      const uint32_t v = s.value(x, y);
      if (s.bpp <= 8) {
        const size_t bit = size_t(x) * size_t(s.bpp);
        row[bit / 8] = char(uint8_t(row[bit / 8]) | uint8_t(v << (8 - s.bpp - bit % 8)));
      } else {
        for (int b = 0; b < s.bpp / 8; ++b) row[size_t(x * s.bpp / 8 + b)] = char(v >> (8 * b));
      }
    }
    out += row;
  }
  return out;
}

// A TGA: `pixels` as the file stores them, bottom row first unless top-down; run-length encoded
// here when `rle`.
struct TgaSpec {
  int type = 2;  // 1 colour-mapped, 2 true colour, 3 grey
  int width = 1, height = 1, bpp = 24;
  bool top_down = false, right_to_left = false, rle = false;
  std::string map;  // colour-map entries as stored
  int map_length = 0, map_bits = 0;
  std::string pixels;
};

std::string tgaFile(const TgaSpec& s) {
  std::string out;
  out.push_back(0);  // no image ID
  out.push_back(char(s.map_length > 0 ? 1 : 0));
  out.push_back(char(s.type + (s.rle ? 8 : 0)));
  putLe(out, 0, 2);
  putLe(out, uint32_t(s.map_length), 2);
  out.push_back(char(s.map_bits));
  putLe(out, 0, 4);  // origin
  putLe(out, uint32_t(s.width), 2);
  putLe(out, uint32_t(s.height), 2);
  out.push_back(char(s.bpp));
  out.push_back(char((s.top_down ? 0x20 : 0) | (s.right_to_left ? 0x10 : 0)));
  out += s.map;
  const size_t px = size_t(s.bpp + 7) / 8;
  if (!s.rle) return out + s.pixels;
  const size_t count = s.pixels.size() / px;
  auto pixel = [&](size_t i) { return s.pixels.substr(i * px, px); };
  for (size_t i = 0; i < count;) {
    size_t run = 1;
    while (i + run < count && run < 128 && pixel(i + run) == pixel(i)) ++run;
    if (run > 1) {
      out.push_back(char(0x80 | (run - 1)));
      out += pixel(i);
      i += run;
      continue;
    }
    size_t raw = 1;
    while (i + raw < count && raw < 128 && pixel(i + raw) != pixel(i + raw - 1)) ++raw;
    out.push_back(char(raw - 1));
    out += s.pixels.substr(i * px, raw * px);
    i += raw;
  }
  return out;
}

// A grey JPEG whose every block is mid-grey, as small as JPEG allows: a baseline one is 2 bits a
// block (a one-bit DC code for "no change" and a one-bit EOB), so 16384 x 16384 pixels take 1 MiB;
// a progressive one is a DC scan of 1 bit a block and `ac_scans` AC scans of 1 bit a block.
std::string flatJpeg(int width, int height, bool progressive = false, int ac_scans = 1) {
  std::string out("\xff\xd8", 2);
  auto segment = [&](int marker, const std::string& body) {
    out.push_back('\xff');
    out.push_back(char(marker));
    putBe(out, uint32_t(body.size() + 2), 2);
    out += body;
  };
  segment(0xdb, std::string(1, '\0') + std::string(64, '\x01'));  // quantisation table 0
  std::string frame(1, '\x08');
  putBe(frame, uint32_t(height), 2);
  putBe(frame, uint32_t(width), 2);
  frame += std::string("\x01\x01\x11\x00", 4);  // one component: id 1, 1x1, table 0
  segment(progressive ? 0xc2 : 0xc0, frame);
  // Huffman tables with one code, "0": DC table 0 -> category 0, AC table 0 -> EOB.
  const std::string counts = std::string(1, '\x01') + std::string(15, '\0');
  segment(0xc4, std::string(1, '\x00') + counts + std::string(1, '\0'));
  segment(0xc4, std::string(1, '\x10') + counts + std::string(1, '\0'));
  const uint64_t blocks = uint64_t((width + 7) / 8) * uint64_t((height + 7) / 8);
  auto scan = [&](int ss, int se, uint64_t bits) {
    segment(0xda, std::string("\x01\x01\x00", 3) + char(ss) + char(se) + '\0');
    out.append(size_t((bits + 7) / 8), '\0');
  };
  if (!progressive) {
    scan(0, 63, 2 * blocks);
  } else {
    scan(0, 0, blocks);
    for (int i = 0; i < ac_scans; ++i) scan(1, 63, blocks);
  }
  out += std::string("\xff\xd9", 2);
  return out;
}

const uint8_t kRed[4] = {255, 0, 0, 255};
const uint8_t kBlue[4] = {0, 0, 255, 255};
const uint8_t kTeal[4] = {0, 128, 128, 255};

std::array<uint8_t, 4> texel(const TextureTexels& t, int x, int y) {
  const size_t i = 4 * (size_t(y) * size_t(t.width) + size_t(x));
  return {t.rgba8[i], t.rgba8[i + 1], t.rgba8[i + 2], t.rgba8[i + 3]};
}

TextureTexels decodeOk(const std::string& name, const std::string& bytes,
                       const ImageLimits& limits = {}) {
  Expected<TextureTexels> t = decodeTextureImage(name, bytes, limits);
  EXPECT_TRUE(t.ok()) << name << ": " << (t.ok() ? "" : t.error().describe());
  return t.ok() ? std::move(*t) : TextureTexels{};
}

// The error's one line, which must name the image.
std::string errorOf(const std::string& name, const std::string& bytes,
                    const ImageLimits& limits = {}) {
  Expected<TextureTexels> t = decodeTextureImage(name, bytes, limits);
  if (t.ok()) return "(decoded)";
  EXPECT_EQ(t.error().file, name);
  EXPECT_EQ(t.error().describe().find('\n'), std::string::npos);
  return t.error().message;
}

#define EXPECT_HAS(text, part) EXPECT_NE(std::string(text).find(part), std::string::npos) << (text)

// The peak memory of a piece of work: the process's high-water mark (VmHWM) is reset through
// /proc/self/clear_refs before and read after. 0 where Linux does not allow the reset.
class PeakMemory {
 public:
  PeakMemory() {
    std::ofstream reset("/proc/self/clear_refs");
    reset << "5";
    reset.flush();
    ok_ = bool(reset);
    start_ = field("VmRSS:");
  }
  // Bytes above the resident size at the start.
  uint64_t rise() const {
    if (!ok_) return 0;
    const uint64_t peak = field("VmHWM:");
    return peak > start_ ? peak - start_ : 0;
  }
  bool ok() const { return ok_; }

 private:
  static uint64_t field(const std::string& key) {
    std::ifstream status("/proc/self/status");
    std::string line;
    while (std::getline(status, line)) {
      if (line.rfind(key, 0) == 0) return std::stoull(line.substr(key.size())) * 1024;
    }
    return 0;
  }
  bool ok_ = false;
  uint64_t start_ = 0;
};

// ---- formats and messages ----------------------------------------------------------------------

TEST(ImageDecode, FormatsAreKnownBySignatureAndTgaByName) {
  const std::string png = test::pngBytes(test::chequer(2, 2, 1, kRed, kRed));
  EXPECT_EQ(imageFormatOf("a.bin", png), ImageFormat::kPng);
  EXPECT_EQ(imageFormatOf("a.png", flatJpeg(8, 8)), ImageFormat::kJpeg);
  EXPECT_EQ(imageFormatOf("a", test::webpBytes(test::chequer(2, 2, 1, kRed, kRed))),
            ImageFormat::kWebp);
  EXPECT_EQ(imageFormatOf("a", "BM......"), ImageFormat::kBmp);
  EXPECT_EQ(imageFormatOf("a.TGA", std::string(18, '\0')), ImageFormat::kTga);
  EXPECT_EQ(imageFormatOf("a.ktx2", std::string("\xabKTX 20\xbb\r\n\x1a\n", 12) + "rest"),
            ImageFormat::kKtx2);
  EXPECT_EQ(imageFormatOf("a.dat", "hello"), ImageFormat::kUnknown);
  EXPECT_STREQ(imageFormatName(ImageFormat::kJpeg), "JPEG");
  EXPECT_STREQ(imageFormatName(ImageFormat::kWebp), "WebP");
}

TEST(ImageDecode, MessagesSayWhatIsWrongInPlainWords) {
  EXPECT_EQ(errorOf("empty.png", ""), "the file is empty");
  EXPECT_HAS(errorOf("x.gif", "GIF89a......"), "a GIF image is not read as a texture");
  EXPECT_HAS(errorOf("x.dat", "hello world"), "not a PNG, JPEG, WebP, BMP or TGA image");
  EXPECT_HAS(errorOf("x.ktx2", std::string("\xabKTX 20\xbb\r\n\x1a\n", 12) + std::string(80, 'x')),
             "KTX2");
  // A 12-bit JPEG (SOF1, precision 12), a lossless one (SOF3), a CMYK one, a DNL height.
  auto frameOnly = [](int marker, int precision, int height, int components) {
    std::string j("\xff\xd8\xff", 3);
    j.push_back(char(marker));
    putBe(j, uint32_t(8 + 3 * components), 2);
    j.push_back(char(precision));
    putBe(j, uint32_t(height), 2);
    putBe(j, 16, 2);
    j.push_back(char(components));
    for (int c = 0; c < components; ++c) j += std::string{char(c + 1), '\x11', '\0'};
    return j + std::string("\xff\xd9", 2);
  };
  EXPECT_EQ(errorOf("deep.jpg", frameOnly(0xc1, 12, 16, 3)),
            "a 12-bit JPEG is not supported (only 8-bit ones)");
  EXPECT_EQ(errorOf("lossless.jpg", frameOnly(0xc3, 8, 16, 3)), "a lossless JPEG is not supported");
  EXPECT_HAS(errorOf("cmyk.jpg", frameOnly(0xc0, 8, 16, 4)), "a CMYK JPEG is not supported");
  EXPECT_HAS(errorOf("dnl.jpg", frameOnly(0xc0, 8, 0, 3)), "DNL marker");
  EXPECT_HAS(errorOf("noscan.jpg", frameOnly(0xc0, 8, 16, 3)), "ends before its first scan");
  // An RLE BMP.
  BmpSpec rle{.width = 4, .height = 4, .bpp = 8, .compression = 1, .palette = {0}};
  rle.value = [](int, int) { return 0u; };
  EXPECT_EQ(errorOf("rle.bmp", bmpFile(rle)),
            "a run-length encoded BMP (RLE8) is not supported: save it uncompressed");
  // Never a library's internal words.
  for (const std::string& m : {errorOf("x.png", std::string("\x89PNG\r\n\x1a\n", 8) + "garbage"),
                               errorOf("x.bmp", "BM"), errorOf("x.tga", "short")}) {
    for (const char* bad : {"outofmem", "unknown image type", "bad_alloc", "Corrupt"}) {
      EXPECT_EQ(m.find(bad), std::string::npos) << m;
    }
  }
}

TEST(ImageDecode, MemoryIsCheckedBeforeDecodingAndSaidInBytes) {
  // A valid 16-bit 16384 x 16384 PNG kept at full size (stb_image said "outofmem").
  const std::string png = test::zeroPng(16384, 16384, 6, 16);
  ImageLimits full;
  full.max_size = 16384;
  Expected<ImageHeader> h = readImageHeader("big.png", png);
  ASSERT_TRUE(h.ok()) << h.error().describe();
  const ImagePlan plan = planImage(*h, full);
  EXPECT_FALSE(plan.reduced);
  EXPECT_GT(plan.peak_bytes, uint64_t(4) << 30);  // 2 GiB of texels, their copy, the pyramid
  MemoryBudgetScope budget(uint64_t(1) << 30);
  const std::string m = errorOf("big.png", png, full);
  EXPECT_HAS(m, "decoding this 16384 x 16384 16-bit PNG needs ");
  EXPECT_HAS(m, "GiB, more than is available (1.0 GiB, limited by the caller's budget)");
}

// ---- decode bombs ------------------------------------------------------------------------------

TEST(ImageDecode, BmpAndTgaBombsWithoutPixelDataAreRefusedFromTheirHeaders) {
  // 54 bytes claiming 32768 x 16384 pixels of 32 bits (2 GiB); stb_image made a black texture of
  // it in 20 s.
  std::string bmp =
      bmpFile(BmpSpec{.width = 1, .height = 1, .bpp = 32, .value = [](int, int) { return 0u; }})
          .substr(0, 54);
  bmp.replace(18, 8, std::string("\x00\x80\x00\x00\x00\x40\x00\x00", 8));
  ASSERT_EQ(bmp.size(), 54u);
  EXPECT_EQ(errorOf("bomb.bmp", bmp),
            "the file is truncated: 32768 x 16384 pixels of 32 bits need 2147483648 bytes from "
            "byte 54, the file has 0");
  // 18 bytes claiming 65535 x 65535 pixels of 32 bits, raw and run-length encoded.
  TgaSpec tga{.type = 2, .width = 65535, .height = 65535, .bpp = 32};
  EXPECT_HAS(errorOf("bomb.tga", tgaFile(tga)), "the file is truncated: 65535 x 65535 pixels");
  tga.rle = true;
  EXPECT_EQ(errorOf("rle.tga", tgaFile(tga)),
            "the file is truncated: its run-length encoded pixels end after 0 of 65535 x 65535");
  // Run-length encoding holds 128 pixels in 5 bytes: 21 MB that stb_image would decode into 2 GiB
  // is refused by name.
  TgaSpec big{.type = 2, .width = 32768, .height = 16384, .bpp = 32, .rle = true};
  std::string packets;
  for (int i = 0; i < 32768 * 16384 / 128; ++i) packets += std::string("\xff\x01\x02\x03\x04", 5);
  EXPECT_EQ(errorOf("big.tga", tgaFile(big).substr(0, 18) + packets),
            "a TGA of 32768 x 16384 pixels is larger than its decoder takes (2 GiB decoded)");
}

TEST(ImageDecode, TruncatedBmpAndTgaFilesAreRefusedAtEveryCut) {
  BmpSpec bmp{.width = 4, .height = 3, .bpp = 24};  // rows of 12 bytes: no padding
  bmp.value = [](int x, int y) { return uint32_t(x * 40 + y * 7) * 0x010101u; };
  BmpSpec indexed{.width = 4, .height = 3, .bpp = 8, .palette = {0xff0000, 0x00ff00}};
  indexed.value = [](int x, int) { return uint32_t(x % 2); };
  TgaSpec raw{.type = 2, .width = 5, .height = 3, .bpp = 24};
  for (int i = 0; i < 15; ++i) raw.pixels += std::string{char(i), char(2 * i), char(3 * i)};
  TgaSpec rle = raw;
  rle.rle = true;
  for (const auto& [name, bytes] : {std::pair<std::string, std::string>{"a.bmp", bmpFile(bmp)},
                                    {"p.bmp", bmpFile(indexed)},
                                    {"a.tga", tgaFile(raw)},
                                    {"r.tga", tgaFile(rle)}}) {
    decodeOk(name, bytes);
    for (size_t cut = 0; cut < bytes.size(); ++cut) {
      const std::string m = errorOf(name, bytes.substr(0, cut));
      // Cut inside "BM" the file is no longer a BMP.
      EXPECT_TRUE(m.find("truncated") != std::string::npos || m == "the file is empty" ||
                  (cut < 2 && m.find("not a PNG, JPEG") != std::string::npos))
          << name << " cut at " << cut << ": " << m;
    }
  }
}

TEST(ImageDecode, APngBombIsReducedWithinItsPlan) {
  // 0.4 MB of image data for 20000 x 20000 grey pixels (400 MB; stb_image took 1.6 GB of it).
  const std::string png = test::zeroPng(20000, 20000, 0, 8);
  EXPECT_LT(png.size(), 500u << 10);
  Expected<ImageHeader> h = readImageHeader("bomb.png", png);
  ASSERT_TRUE(h.ok()) << h.error().describe();
  const ImagePlan plan = planImage(*h, ImageLimits{});
  EXPECT_TRUE(plan.reduced);
  EXPECT_EQ(plan.width, 5000);  // reduced by 4
  EXPECT_EQ(plan.texture_bytes, Texture::plannedBytes(5000, 5000, false));
  EXPECT_LT(plan.peak_bytes, uint64_t(300) << 20);
  PeakMemory peak;
  const TextureTexels t = decodeOk("bomb.png", png);
  EXPECT_EQ(t.width, 5000);
  EXPECT_EQ(t.file_width, 20000);
  EXPECT_TRUE(t.reduced());
  ASSERT_FALSE(t.warnings.empty());
  EXPECT_EQ(t.warnings[0],
            "reduced from 20000 x 20000 to 5000 x 5000: larger than the texture size limit (8192 "
            "a side)");
  EXPECT_EQ(texel(t, 4999, 4999), (std::array<uint8_t, 4>{0, 0, 0, 255}));
  if (peak.ok()) {
    EXPECT_LE(peak.rise(), plan.peak_bytes - plan.texture_bytes);
  }
}

TEST(ImageDecode, ASixteenBitPngBombIsReducedWithinItsPlan) {
  // 16384 x 16384 16-bit RGBA: 2 GiB decoded from 2 MB (stb_image took 4.8 GB and 93 s). The plan
  // keeps 8192 x 8192 of it.
  const std::string png = test::zeroPng(16384, 16384, 6, 16);
  Expected<ImageHeader> h = readImageHeader("bomb16.png", png);
  ASSERT_TRUE(h.ok()) << h.error().describe();
  EXPECT_TRUE(h->sixteen_bit);
  const ImagePlan plan = planImage(*h, ImageLimits{});
  EXPECT_EQ(plan.width, 8192);
  EXPECT_EQ(plan.texture_bytes, Texture::plannedBytes(8192, 8192, true));
  EXPECT_LT(plan.peak_bytes, uint64_t(2) << 30);
  // Decoded (grey, to keep the test short: inflating 2 GiB takes 10 s), within its plan.
  const std::string grey = test::zeroPng(16384, 16384, 0, 16);
  Expected<ImageHeader> g = readImageHeader("grey16.png", grey);
  ASSERT_TRUE(g.ok()) << g.error().describe();
  const ImagePlan grey_plan = planImage(*g, ImageLimits{});
  PeakMemory peak;
  const TextureTexels t = decodeOk("grey16.png", grey);
  EXPECT_TRUE(t.sixteen_bit);
  EXPECT_EQ(t.rgba16.size(), 4u * 8192 * 8192);
  EXPECT_EQ(t.rgba16[4 * 8192 * 8192 - 1], 65535);
  if (peak.ok()) {
    EXPECT_LE(peak.rise(), grey_plan.peak_bytes - grey_plan.texture_bytes);
  }
}

TEST(ImageDecode, AJpegBombIsDecodedAtAFractionWithinItsPlan) {
  // 1 MiB of baseline JPEG for 16384 x 16384 pixels: libjpeg decodes it at 1/2 scale.
  const std::string jpeg = flatJpeg(16384, 16384);
  EXPECT_LE(jpeg.size(), (1u << 20) + 200);
  Expected<ImageHeader> h = readImageHeader("bomb.jpg", jpeg);
  ASSERT_TRUE(h.ok()) << h.error().describe();
  EXPECT_EQ(h->full_size_buffer_bytes, 0u);  // one scan: libjpeg streams rows
  const ImagePlan plan = planImage(*h, ImageLimits{});
  EXPECT_EQ(plan.width, 8192);
  EXPECT_LT(plan.peak_bytes, uint64_t(700) << 20);
  PeakMemory peak;
  const TextureTexels t = decodeOk("bomb.jpg", jpeg);
  EXPECT_EQ(t.width, 8192);
  EXPECT_EQ(texel(t, 100, 8000), (std::array<uint8_t, 4>{128, 128, 128, 255}));
  if (peak.ok()) {
    EXPECT_LE(peak.rise(), plan.peak_bytes - plan.texture_bytes);
  }
  // The same image progressive: libjpeg keeps every coefficient (512 MiB), whatever the scale,
  // and the plan says so; at 1/8 of the limit it is still planned, and refused when it does not
  // fit.
  const std::string progressive = flatJpeg(16384, 16384, true);
  Expected<ImageHeader> p = readImageHeader("p.jpg", progressive);
  ASSERT_TRUE(p.ok()) << p.error().describe();
  EXPECT_EQ(p->full_size_buffer_bytes, uint64_t(16384) * 16384 * 2);
  ImageLimits small;
  small.max_size = 1024;
  const ImagePlan pp = planImage(*p, small);
  EXPECT_GT(pp.peak_bytes, uint64_t(512) << 20);
  {
    // One of 8192 x 8192 decodes within its plan, coefficients included.
    const std::string p8 = flatJpeg(8192, 8192, true);
    Expected<ImageHeader> h8 = readImageHeader("p8.jpg", p8);
    ASSERT_TRUE(h8.ok()) << h8.error().describe();
    const ImagePlan plan8 = planImage(*h8, ImageLimits{});
    PeakMemory peak8;
    EXPECT_EQ(decodeOk("p8.jpg", p8).width, 8192);
    if (peak8.ok()) {
      EXPECT_LE(peak8.rise(), plan8.peak_bytes - plan8.texture_bytes);
      EXPECT_GE(peak8.rise(), h8->full_size_buffer_bytes);
    }
  }
  MemoryBudgetScope budget(uint64_t(256) << 20);
  EXPECT_HAS(errorOf("p.jpg", progressive, small),
             "decoding this 16384 x 16384 JPEG (reduced to "
             "1024 x 1024) needs ");
}

TEST(ImageDecode, AJpegScanBombIsStoppedByTheScanBudget) {
  // A DC scan and 600 AC scans (each re-walks every block; 150,000 of them ran past 120 s).
  const std::string bomb = flatJpeg(64, 64, true, 600);
  EXPECT_EQ(errorOf("scans.jpg", bomb),
            "the JPEG has more than 500 scans (a progressive JPEG has about 10; each scan rereads "
            "the whole image): decoding stopped at scan 501");
  // Counted exactly: 601 scans pass a budget of 601 and fail one of 600.
  ImageLimits limits;
  limits.max_scans = 601;
  EXPECT_EQ(decodeOk("scans.jpg", bomb, limits).width, 64);
  limits.max_scans = 600;
  EXPECT_HAS(errorOf("scans.jpg", bomb, limits), "more than 600 scans");
}

TEST(ImageDecode, TheTimeBudgetStopsADecoder) {
  ImageLimits limits;
  limits.max_seconds = 0;
  for (const auto& [name, bytes] :
       {std::pair<std::string, std::string>{"t.jpg", flatJpeg(256, 256, true, 3)},
        {"t.png", test::zeroPng(256, 256, 2, 8)}}) {
    EXPECT_EQ(errorOf(name, bytes, limits),
              "decoding it took longer than 0 s, the limit for one image");
  }
}

// ---- PNG ---------------------------------------------------------------------------------------

TEST(ImageDecode, PalettePngsOfEveryDepthDecodeToTheirColours) {
  for (int depth : {1, 2, 4, 8}) {
    const int colours = 1 << std::min(depth, 4);
    test::PngSpec s{.width = 7, .height = 3, .colour_type = 3, .bit_depth = depth};
    for (int i = 0; i < colours; ++i) {
      s.palette.insert(s.palette.end(), {uint8_t(17 * i), uint8_t(255 - 9 * i), uint8_t(i)});
    }
    s.palette_alpha = {10, 20};  // the first two colours translucent
    for (int i = 0; i < 21; ++i) s.samples.push_back(uint16_t((i * 5) % colours));
    const TextureTexels t = decodeOk("p.png", test::encodePng(s));
    ASSERT_EQ(t.width, 7) << depth;
    EXPECT_EQ(t.channels, 4) << depth;
    EXPECT_TRUE(t.warnings.empty()) << depth;
    for (int i = 0; i < 21; ++i) {
      const int c = (i * 5) % colours;
      const std::array<uint8_t, 4> want{uint8_t(17 * c), uint8_t(255 - 9 * c), uint8_t(c),
                                        uint8_t(c == 0   ? 10
                                                : c == 1 ? 20
                                                         : 255)};
      EXPECT_EQ(texel(t, i % 7, i / 7), want) << depth << "-bit, pixel " << i;
    }
  }
  // A one-colour 1-bit palette PNG of 8192 x 8192 is 8 KB: 32768 times smaller than its RGBA
  // texels, which the old "more than its bytes can hold" check refused.
  const std::string big = test::zeroPng(8192, 8192, 3, 1);
  EXPECT_LT(big.size(), 16u << 10);
  Expected<ImageHeader> h = readImageHeader("one.png", big);
  ASSERT_TRUE(h.ok()) << h.error().describe();
  EXPECT_EQ(h->bits, 1);
  EXPECT_TRUE(h->palette);
  EXPECT_EQ(h->channels, 3);
}

TEST(ImageDecode, PngPaletteIndicesPastThePaletteAreOpaqueBlackEveryRun) {
  // A 4-bit palette of 3 colours, pixels using indices 0 to 15.
  test::PngSpec s{.width = 16, .height = 2, .colour_type = 3, .bit_depth = 4};
  s.palette = {255, 0, 0, 0, 255, 0, 0, 0, 255};
  s.palette_alpha = {100};
  s.unchecked_indices = true;
  for (int i = 0; i < 32; ++i) s.samples.push_back(uint16_t(i % 16));
  const std::string png = test::encodePng(s);
  const TextureTexels a = decodeOk("past.png", png);
  const TextureTexels b = decodeOk("past.png", png);
  ASSERT_EQ(a.width, 16);
  EXPECT_EQ(a.rgba8, b.rgba8);
  EXPECT_EQ(texel(a, 0, 0), (std::array<uint8_t, 4>{255, 0, 0, 100}));
  EXPECT_EQ(texel(a, 2, 0), (std::array<uint8_t, 4>{0, 0, 255, 255}));
  for (int x = 3; x < 16; ++x) EXPECT_EQ(texel(a, x, 1), (std::array<uint8_t, 4>{0, 0, 0, 255}));
  ASSERT_EQ(a.warnings.size(), 1u);
  EXPECT_EQ(a.warnings[0],
            "pixels use colour 15, past the 3 of its palette: they read as opaque black");
}

TEST(ImageDecode, GreyAndSixteenBitPngsKeepTheirValues) {
  // 2-bit grey: 0, 85, 170, 255; grey and alpha; 16-bit grey and RGB with a tRNS colour.
  test::PngSpec g{
      .width = 4, .height = 1, .colour_type = 0, .bit_depth = 2, .samples = {0, 1, 2, 3}};
  const TextureTexels grey = decodeOk("g.png", test::encodePng(g));
  EXPECT_EQ(grey.channels, 1);
  EXPECT_EQ(texel(grey, 2, 0), (std::array<uint8_t, 4>{170, 170, 170, 255}));
  test::PngSpec ga{.width = 1, .height = 1, .colour_type = 4, .bit_depth = 8, .samples = {9, 77}};
  const TextureTexels grey_alpha = decodeOk("ga.png", test::encodePng(ga));
  EXPECT_EQ(grey_alpha.channels, 2);
  EXPECT_EQ(texel(grey_alpha, 0, 0), (std::array<uint8_t, 4>{9, 9, 9, 77}));
  test::PngSpec s16{
      .width = 2, .height = 1, .colour_type = 0, .bit_depth = 16, .samples = {1, 65534}};
  const TextureTexels sixteen = decodeOk("s.png", test::encodePng(s16));
  ASSERT_TRUE(sixteen.sixteen_bit);
  EXPECT_EQ(sixteen.rgba16, (std::vector<uint16_t>{1, 1, 1, 65535, 65534, 65534, 65534, 65535}));
  Expected<Image> data = decodeDataImage("s.png", test::encodePng(s16));
  ASSERT_TRUE(data.ok()) << data.error().describe();
  EXPECT_FLOAT_EQ(data->pixels[0].x, float(1.0 / 65535.0));
  EXPECT_FLOAT_EQ(data->pixels[1].z, float(65534.0 / 65535.0));
}

TEST(ImageDecode, InterlacedPngsDecodeAsPlainOnesAtEverySize) {
  for (const auto& [w, h] : {std::pair{1, 1}, {3, 5}, {17, 9}, {64, 33}}) {
    test::PngSpec s{.width = w, .height = h, .colour_type = 2, .bit_depth = 8};
    for (int i = 0; i < w * h * 3; ++i) s.samples.push_back(uint16_t((i * 37) % 256));
    const std::string plain = test::encodePng(s);
    s.interlaced = true;
    const std::string interlaced = test::encodePng(s);
    for (int max_size : {4096, 8, 2}) {
      ImageLimits limits;
      limits.max_size = max_size;
      const TextureTexels a = decodeOk("plain.png", plain, limits);
      const TextureTexels b = decodeOk("adam7.png", interlaced, limits);
      EXPECT_EQ(a.width, b.width);
      EXPECT_EQ(a.rgba8, b.rgba8) << w << " x " << h << ", limit " << max_size;
    }
  }
}

TEST(ImageDecode, ReductionTakesTheMeanOfTheTexelsCovered) {
  // 10 x 7 RGB with distinct values, reduced by 4 to 3 x 2: the last column covers 2 texels and
  // the last row 3, each output the rounded mean of what it covers.
  const int w = 10, h = 7;
  test::PngSpec s{.width = w, .height = h, .colour_type = 2, .bit_depth = 8};
  auto value = [](int x, int y, int c) { return (x * 23 + y * 11 + c * 50) % 256; };
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      for (int c = 0; c < 3; ++c) s.samples.push_back(uint16_t(value(x, y, c)));
    }
  }
  ImageLimits limits;
  limits.max_size = 3;
  const TextureTexels t = decodeOk("r.png", test::encodePng(s), limits);
  ASSERT_EQ(t.width, 3);
  ASSERT_EQ(t.height, 2);
  for (int oy = 0; oy < 2; ++oy) {
    for (int ox = 0; ox < 3; ++ox) {
      for (int c = 0; c < 3; ++c) {
        int sum = 0, count = 0;
        for (int y = oy * 4; y < std::min(h, oy * 4 + 4); ++y) {
          for (int x = ox * 4; x < std::min(w, ox * 4 + 4); ++x, ++count) sum += value(x, y, c);
        }
        EXPECT_EQ(texel(t, ox, oy)[size_t(c)], (sum + count / 2) / count) << ox << "," << oy;
      }
    }
  }
}

// The chunk of `type` in a PNG: its offset.
size_t chunkAt(const std::string& png, const std::string& type) {
  return png.find(type) - 4;
}

TEST(ImageDecode, PngCrcsAreChecked) {
  test::PngSpec s{.width = 2,
                  .height = 2,
                  .colour_type = 3,
                  .bit_depth = 8,
                  .samples = {0, 1, 1, 0},
                  .palette = {255, 0, 0, 0, 0, 255},
                  .palette_alpha = {128}};
  const std::string png = test::encodePng(s);
  // A CRC that does not match a chunk that holds pixels is an error naming the chunk.
  for (const std::string type : {"IHDR", "PLTE", "tRNS", "IDAT"}) {
    std::string bad = png;
    const size_t chunk = chunkAt(bad, type);
    uint32_t length = 0;
    for (int k = 0; k < 4; ++k) length = length << 8 | uint8_t(bad[chunk + size_t(k)]);
    const size_t at = chunk + 8 + length;  // the CRC's first byte
    bad[at] = char(bad[at] ^ 0x01);
    EXPECT_HAS(errorOf("crc.png", bad),
               "the file is damaged: chunk " + type + " fails its CRC check");
  }
  // In a text chunk, which Penumbra does not read, it is a warning.
  std::string text = png;
  std::string chunk;
  putBe(chunk, 5, 4);
  chunk += std::string("tEXtab\0cd", 9);
  putBe(chunk, 0xdeadbeef, 4);  // not its CRC
  text.insert(chunkAt(text, "IDAT"), chunk);
  const TextureTexels t = decodeOk("text.png", text);
  EXPECT_EQ(texel(t, 0, 0), (std::array<uint8_t, 4>{255, 0, 0, 128}));
  ASSERT_EQ(t.warnings.size(), 1u);
  EXPECT_EQ(t.warnings[0], "chunk tEXt fails its CRC check: ignored (Penumbra does not use it)");
}

TEST(ImageDecode, APngWithLessImageDataThanItsHeaderClaimsIsRefused) {
  std::string png = test::pngBytes(test::chequer(2, 2, 1, kRed, kRed));
  png[16] = '\x7f';                       // width's top byte
  std::string ihdr = png.substr(12, 17);  // recompute the IHDR CRC so only the size is wrong
  const uint32_t crc = uint32_t(crc32(0, reinterpret_cast<const Bytef*>(ihdr.data()), 17));
  std::string crc_bytes;
  putBe(crc_bytes, crc, 4);
  png.replace(29, 4, crc_bytes);
  EXPECT_HAS(errorOf("big.png", png), "more than its");
  EXPECT_HAS(errorOf("big.png", png), "bytes of image data can hold");
  // Cut in its image data: refused from the header, before libpng inflates anything.
  const std::string ok = test::pngBytes(test::chequer(16, 16, 2, kRed, kBlue));
  for (size_t cut = 8; cut < ok.size(); ++cut) {
    EXPECT_HAS(errorOf("cut.png", ok.substr(0, cut)), "truncated");
  }
}

// ---- JPEG, WebP, BMP, TGA
// -------------------------------------------------------------------------

TEST(ImageDecode, JpegsDecodeBaselineProgressiveAndGreyAndReduceInTheDct) {
  const Rgba8Image img = test::chequer(64, 64, 2, kRed, kTeal);
  for (bool progressive : {false, true}) {
    const TextureTexels t = decodeOk("c.jpg", test::encodeJpeg(img, 95, progressive));
    EXPECT_EQ(t.channels, 3);
    const auto red = texel(t, 5, 5);
    EXPECT_NEAR(red[0], 255, 4);
    EXPECT_NEAR(red[1], 0, 4);
    const auto teal = texel(t, 40, 5);
    EXPECT_NEAR(teal[1], 128, 4);
    // Reduced by 4 in the DCT: the quadrants keep their colours.
    ImageLimits limits;
    limits.max_size = 16;
    const TextureTexels r = decodeOk("c.jpg", test::encodeJpeg(img, 95, progressive), limits);
    ASSERT_EQ(r.width, 16);
    EXPECT_NEAR(texel(r, 2, 2)[0], 255, 8);
    EXPECT_NEAR(texel(r, 12, 2)[2], 128, 8);
    // By 32: 1/8 in the DCT, then a box of 4.
    limits.max_size = 2;
    const TextureTexels q = decodeOk("c.jpg", test::encodeJpeg(img, 95, progressive), limits);
    ASSERT_EQ(q.width, 2);
    EXPECT_NEAR(texel(q, 0, 0)[0], 255, 8);
    EXPECT_NEAR(texel(q, 1, 0)[1], 128, 8);
  }
  const TextureTexels g = decodeOk("g.jpg", test::encodeJpeg(img, 95, false, true));
  EXPECT_EQ(g.channels, 1);
  EXPECT_NEAR(texel(g, 5, 5)[1], 255, 4);  // the red channel, as grey
  // Cut short: an error, not grey rows.
  const std::string jpeg = test::encodeJpeg(img, 95);
  EXPECT_HAS(errorOf("cut.jpg", jpeg.substr(0, jpeg.size() - 100)), "truncated");
}

TEST(ImageDecode, OneColourWebpsDecode) {
  // Refused before as "claims N x N pixels, more than its B bytes can hold".
  for (int size : {128, 1024, 2048}) {
    const std::string lossless = test::webpBytes(test::chequer(size, size, 1, kTeal, kTeal));
    EXPECT_LT(lossless.size(), 400u);
    const TextureTexels t = decodeOk("one.webp", lossless);
    EXPECT_EQ(t.width, size);
    EXPECT_EQ(texel(t, size - 1, size / 2), (std::array<uint8_t, 4>{0, 128, 128, 255}));
  }
  for (int size : {512, 2048}) {
    const TextureTexels t =
        decodeOk("one.webp", test::webpLossyBytes(test::chequer(size, size, 1, kTeal, kTeal)));
    EXPECT_EQ(t.width, size);
    EXPECT_NEAR(texel(t, 7, 7)[1], 128, 3);
  }
  // Reduced through libwebp's scaler.
  ImageLimits limits;
  limits.max_size = 100;
  const TextureTexels r =
      decodeOk("one.webp", test::webpBytes(test::chequer(1024, 1024, 1, kTeal, kTeal)), limits);
  EXPECT_EQ(r.width, 64);
  EXPECT_EQ(texel(r, 63, 63), (std::array<uint8_t, 4>{0, 128, 128, 255}));
}

TEST(ImageDecode, BmpsOfEveryDepthReadTopDownOrBottomUp) {
  // A 5 x 3 image whose pixel (x, y) is colour x + 5y (of 15 colours).
  auto colour = [](int x, int y) { return uint32_t((x * 50) << 16 | (y * 80) << 8 | (x + y)); };
  std::vector<uint32_t> palette;
  for (int i = 0; i < 15; ++i) palette.push_back(colour(i % 5, i / 5));
  for (bool top_down : {false, true}) {
    for (int bpp : {4, 8, 24, 32}) {
      BmpSpec s{.width = 5, .height = 3, .bpp = bpp, .top_down = top_down};
      if (bpp <= 8) s.palette = palette;
      s.value = [&](int x, int y) { return bpp <= 8 ? uint32_t(x + 5 * y) : colour(x, y); };
      const TextureTexels t = decodeOk("a.bmp", bmpFile(s));
      ASSERT_EQ(t.height, 3);
      EXPECT_EQ(t.channels, 3) << bpp;  // a 32-bit BMP whose fourth byte is 0 has no alpha
      for (int y = 0; y < 3; ++y) {
        for (int x = 0; x < 5; ++x) {
          const uint32_t c = colour(x, y);
          EXPECT_EQ(texel(t, x, y),
                    (std::array<uint8_t, 4>{uint8_t(c >> 16), uint8_t(c >> 8), uint8_t(c), 255}))
              << bpp << "-bit, top-down " << top_down << ", " << x << "," << y;
        }
      }
    }
  }
  // 1-bit, 16-bit 5-5-5 and 5-6-5 bit fields, and 32-bit with alpha in a V4 header.
  BmpSpec one{.width = 9, .height = 2, .bpp = 1, .palette = {0x000000, 0xffffff}};
  one.value = [](int x, int) { return uint32_t(x % 3 == 0); };
  EXPECT_EQ(texel(decodeOk("1.bmp", bmpFile(one)), 3, 1),
            (std::array<uint8_t, 4>{255, 255, 255, 255}));
  BmpSpec s555{.width = 2, .height = 1, .bpp = 16};
  s555.value = [](int x, int) { return x == 0 ? 0x7c00u : 0x001fu; };
  EXPECT_EQ(texel(decodeOk("555.bmp", bmpFile(s555)), 1, 0),
            (std::array<uint8_t, 4>{0, 0, 255, 255}));
  BmpSpec s565{
      .width = 1, .height = 1, .bpp = 16, .compression = 3, .masks = {0xf800, 0x07e0, 0x001f, 0}};
  s565.value = [](int, int) { return 0x07e0u; };
  EXPECT_EQ(texel(decodeOk("565.bmp", bmpFile(s565)), 0, 0),
            (std::array<uint8_t, 4>{0, 255, 0, 255}));
  BmpSpec v4{.width = 1,
             .height = 1,
             .bpp = 32,
             .compression = 3,
             .masks = {0x00ff0000, 0x0000ff00, 0x000000ff, 0xff000000},
             .v4_header = true};
  v4.value = [](int, int) { return 0x40102030u; };
  const TextureTexels a = decodeOk("v4.bmp", bmpFile(v4));
  EXPECT_EQ(a.channels, 4);
  EXPECT_EQ(texel(a, 0, 0), (std::array<uint8_t, 4>{0x10, 0x20, 0x30, 0x40}));
  // Reduced while it is read.
  BmpSpec big{.width = 300, .height = 200, .bpp = 24};
  big.value = [](int x, int) { return x < 150 ? 0xff0000u : 0x0000ffu; };
  ImageLimits limits;
  limits.max_size = 100;
  const TextureTexels r = decodeOk("big.bmp", bmpFile(big), limits);
  EXPECT_EQ(r.width, 75);
  EXPECT_EQ(texel(r, 0, 0), (std::array<uint8_t, 4>{255, 0, 0, 255}));
  EXPECT_EQ(texel(r, 74, 49), (std::array<uint8_t, 4>{0, 0, 255, 255}));
}

TEST(ImageDecode, BmpPaletteIndicesPastThePaletteAreOpaqueBlack) {
  BmpSpec s{.width = 4, .height = 1, .bpp = 8, .palette = {0x112233, 0x445566}};
  s.value = [](int x, int) { return uint32_t(x * 60); };
  const TextureTexels t = decodeOk("p.bmp", bmpFile(s));
  EXPECT_EQ(texel(t, 0, 0), (std::array<uint8_t, 4>{0x11, 0x22, 0x33, 255}));
  EXPECT_EQ(texel(t, 3, 0), (std::array<uint8_t, 4>{0, 0, 0, 255}));
  ASSERT_EQ(t.warnings.size(), 1u);
  EXPECT_EQ(t.warnings[0],
            "pixels use colour 180, past the 2 of its palette: they read as opaque "
            "black");
}

TEST(ImageDecode, TgasOfEveryKindDecode) {
  // 3 x 2: bottom row first in the file unless top-down.
  auto bgr = [](int x, int y) { return std::string{char(x * 10), char(y * 100), char(200)}; };
  for (bool rle : {false, true}) {
    for (bool top_down : {false, true}) {
      TgaSpec s{.type = 2, .width = 3, .height = 2, .bpp = 24, .top_down = top_down, .rle = rle};
      for (int r = 0; r < 2; ++r) {
        for (int x = 0; x < 3; ++x) s.pixels += bgr(x, top_down ? r : 1 - r);
      }
      const TextureTexels t = decodeOk("a.tga", tgaFile(s));
      EXPECT_EQ(texel(t, 2, 1), (std::array<uint8_t, 4>{200, 100, 20, 255})) << rle << top_down;
      EXPECT_EQ(texel(t, 0, 0), (std::array<uint8_t, 4>{200, 0, 0, 255})) << rle << top_down;
    }
  }
  // Right to left.
  TgaSpec mirrored{.type = 3,
                   .width = 3,
                   .height = 1,
                   .bpp = 8,
                   .top_down = true,
                   .right_to_left = true,
                   .pixels = std::string("\x01\x02\x03", 3)};
  EXPECT_EQ(texel(decodeOk("m.tga", tgaFile(mirrored)), 0, 0),
            (std::array<uint8_t, 4>{3, 3, 3, 255}));
  // Colour-mapped with an index past the map: its first colour (stb_image's rule), with a warning.
  TgaSpec mapped{.type = 1,
                 .width = 2,
                 .height = 1,
                 .bpp = 8,
                 .top_down = true,
                 .map = std::string("\x01\x02\x03\x04\x05\x06", 6),
                 .map_length = 2,
                 .map_bits = 24,
                 .pixels = std::string("\x01\x07", 2)};
  const TextureTexels m = decodeOk("map.tga", tgaFile(mapped));
  EXPECT_EQ(texel(m, 0, 0), (std::array<uint8_t, 4>{6, 5, 4, 255}));
  EXPECT_EQ(texel(m, 1, 0), (std::array<uint8_t, 4>{3, 2, 1, 255}));
  ASSERT_EQ(m.warnings.size(), 1u);
  EXPECT_HAS(m.warnings[0], "past the 2 of its colour map");
  // 32-bit with alpha.
  TgaSpec alpha{
      .type = 2, .width = 1, .height = 1, .bpp = 32, .pixels = std::string("\x01\x02\x03\x04", 4)};
  const TextureTexels a = decodeOk("a32.tga", tgaFile(alpha));
  EXPECT_EQ(a.channels, 4);
  EXPECT_EQ(texel(a, 0, 0), (std::array<uint8_t, 4>{3, 2, 1, 4}));
}

// ---- data images (normal maps)
// -------------------------------------------------------------------

TEST(ImageDecode, JpegAndWebpNormalMapsDecodeAsData) {
  const uint8_t normal[4] = {128, 128, 255, 255};
  const Rgba8Image img = test::chequer(16, 16, 1, normal, normal);
  test::TempDir dir;
  for (const auto& [name, bytes] :
       {std::pair<std::string, std::string>{"n.jpg", test::encodeJpeg(img, 100)},
        {"n.webp", test::webpBytes(img)},
        {"n.png", test::pngBytes(img)},
        {"n.tga", tgaFile(TgaSpec{.type = 2,
                  .width = 1,
                  .height = 1,
                  .bpp = 24,
                  .pixels = std::string("\xff\x80\x80", 3)})}}) {
    for (const Expected<Image>& data :
         {decodeDataImage(name, bytes), readImageData(dir.write(name, bytes))}) {
      ASSERT_TRUE(data.ok()) << name << ": " << data.error().describe();
      EXPECT_NEAR(data->pixels[0].x, 128.0f / 255.0f, 1.5f / 255.0f) << name;
      EXPECT_NEAR(data->pixels[0].z, 1.0f, 1.5f / 255.0f) << name;
    }
  }
  // A JSON scene's normal map in JPEG, reduced to the limit with a warning.
  dir.write("quad.obj",
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
            "f 1/1 2/2 3/3 4/4\n");
  dir.write("big.jpg", flatJpeg(16384, 8));
  const nlohmann::json scene = {
      {"materials", {{"bumpy", {{"reflectance", {0.5, 0.5, 0.5}}, {"normal_map", "big.jpg"}}}}},
      {"meshes", {{{"file", "quad.obj"}, {"material", "bumpy"}}}}};
  Expected<Scene> s = loadScene(dir.write("scene.json", scene.dump()));
  ASSERT_TRUE(s.ok()) << s.error().describe();
  ASSERT_TRUE(s->materials.back().normal_map);
  EXPECT_EQ(s->materials.back().normal_map->width, 8192);
  const std::string want = "big.jpg': reduced from 16384 x 8 to 8192 x 4";
  EXPECT_TRUE(std::any_of(s->warnings.begin(), s->warnings.end(), [&](const std::string& w) {
    return w.find(want) != std::string::npos;
  })) << ::testing::PrintToString(s->warnings);
}

TEST(ImageDecode, PlansAreArithmeticOnTheHeader) {
  ImageHeader h;
  h.format = ImageFormat::kWebp;
  h.width = 16000;
  h.height = 4000;
  h.channels = 4;
  h.full_size_buffer_bytes = uint64_t(4) * 16000 * 4000;  // lossless
  const ImagePlan p = planImage(h, ImageLimits{});
  EXPECT_EQ(p.width, 8000);
  EXPECT_EQ(p.height, 2000);
  EXPECT_TRUE(p.reduced);
  EXPECT_EQ(p.texture_bytes, Texture::plannedBytes(8000, 2000, false));
  EXPECT_GE(p.peak_bytes, h.full_size_buffer_bytes + p.texture_bytes + 4u * 8000 * 2000);
  const ImagePlan d = planDataImage(h, ImageLimits{});
  EXPECT_EQ(d.texture_bytes, 12u * 8000 * 2000);
  ImageHeader small = h;
  small.width = small.height = 100;
  small.full_size_buffer_bytes = 0;
  const ImagePlan q = planImage(small, ImageLimits{});
  EXPECT_FALSE(q.reduced);
  const std::vector<ImagePlan> plans = {p, q};
  EXPECT_EQ(plannedSceneBytes(plans),
            p.texture_bytes + q.texture_bytes +
                std::max(p.peak_bytes - p.texture_bytes, q.peak_bytes - q.texture_bytes));
  // A lossless WebP's header says how much libwebp holds.
  Expected<ImageHeader> w =
      readImageHeader("w.webp", test::webpBytes(test::chequer(300, 200, 1, kRed, kRed)));
  ASSERT_TRUE(w.ok()) << w.error().describe();
  EXPECT_EQ(w->full_size_buffer_bytes, 4u * 300 * 200);
}

}  // namespace
}  // namespace penumbra
