// Image files: lossless round trips for .exr and .pfm, RGBE precision for .hdr, sRGB 8-bit
// quantisation for .png, orientation (row 0 on top), and errors that name the file and leave no
// partial or temporary file behind.
#include "penumbra/io/image_io.h"

#include "support/test_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace penumbra {
namespace {

namespace fs = std::filesystem;

// A non-square image with a distinct value in every channel of every pixel, so that a swapped
// axis, a flipped row order or a channel mix-up shows.
Image testImage(int w, int h, float lo, float hi, uint32_t seed = 7) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(std::log2(lo), std::log2(hi));
  Image img(w, h);
  for (glm::vec3& p : img.pixels)
    p = glm::vec3(std::exp2(u(rng)), std::exp2(u(rng)), std::exp2(u(rng)));
  return img;
}

std::vector<std::string> directoryEntries(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir))
    names.push_back(entry.path().filename().string());
  return names;
}

std::string readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

bool sameBits(float a, float b) {
  return std::bit_cast<uint32_t>(a) == std::bit_cast<uint32_t>(b);
}

void expectBitExact(const Image& a, const Image& b) {
  ASSERT_EQ(a.width, b.width);
  ASSERT_EQ(a.height, b.height);
  ASSERT_EQ(a.pixels.size(), b.pixels.size());
  for (size_t i = 0; i < a.pixels.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      ASSERT_TRUE(sameBits(a.pixels[i][c], b.pixels[i][c]))
          << "pixel " << i << " channel " << c << ": " << a.pixels[i][c] << " vs "
          << b.pixels[i][c];
    }
  }
}

// IEC 61966-2-1 inverse transfer function.
double decodeSrgb(double v) {
  return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

// ---- a minimal PNG writer (stored deflate blocks), independent of the code under test --------

uint32_t crc32(const std::string& bytes) {
  uint32_t crc = 0xffffffffu;
  for (unsigned char byte : bytes) {
    crc ^= byte;
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

void appendBe32(std::string& out, uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) out.push_back(char((v >> s) & 0xffu));
}

void appendChunk(std::string& png, const std::string& type, const std::string& data) {
  appendBe32(png, uint32_t(data.size()));
  const std::string body = type + data;
  png += body;
  appendBe32(png, crc32(body));
}

// An RGB PNG, bit depth 8 or 16; `samples` holds w*h*3 values, rows from the top.
std::string makePng(int w, int h, int bit_depth, const std::vector<uint16_t>& samples) {
  std::string raw;
  for (int y = 0; y < h; ++y) {
    raw.push_back(0);  // filter type None
    for (int i = 0; i < w * 3; ++i) {
      const uint16_t v = samples[size_t(y * w * 3 + i)];
      if (bit_depth == 16) raw.push_back(char(v >> 8));
      raw.push_back(char(v & 0xff));
    }
  }
  std::string zlib = {0x78, 0x01, 0x01};  // zlib header; one final stored block
  const uint16_t len = uint16_t(raw.size());
  zlib += {char(len & 0xff), char(len >> 8), char(~len & 0xff), char((~len >> 8) & 0xff)};
  zlib += raw;
  uint32_t a = 1, b = 0;  // Adler-32
  for (unsigned char c : raw) {
    a = (a + c) % 65521u;
    b = (b + a) % 65521u;
  }
  appendBe32(zlib, (b << 16) | a);

  std::string png("\x89PNG\r\n\x1a\n", 8);
  std::string ihdr;
  appendBe32(ihdr, uint32_t(w));
  appendBe32(ihdr, uint32_t(h));
  ihdr += {char(bit_depth), 2, 0, 0, 0};  // RGB, deflate, no filter, no interlace
  appendChunk(png, "IHDR", ihdr);
  appendChunk(png, "IDAT", zlib);
  appendChunk(png, "IEND", "");
  return png;
}

// ---- tests --------------------------------------------------------------------------------------

TEST(ImageIoTest, SupportedExtensions) {
  for (const char* p : {"a.exr", "a.hdr", "a.pfm", "a.png", "dir.x/B.EXR", "c.Png"}) {
    EXPECT_TRUE(isSupportedImageExtension(p)) << p;
  }
  for (const char* p : {"a.jpg", "a.xyz", "exr", "a.exr.tmp", "dir.exr/file", ""}) {
    EXPECT_FALSE(isSupportedImageExtension(p)) << p;
  }
}

TEST(ImageIoTest, ExrRoundTripIsBitExact) {
  test::TempDir dir;
  Image img = testImage(37, 23, 1e-6f, 1e6f);
  // Values a display never shows still survive a linear format.
  img.at(0, 0) = glm::vec3(-1.5f, 0.0f, -0.0f);
  img.at(1, 0) = glm::vec3(std::numeric_limits<float>::max(),
                           std::numeric_limits<float>::denorm_min(), 1e-30f);
  img.at(2, 0) = glm::vec3(std::numeric_limits<float>::infinity(), 3.0f, 4.0f);
  const std::string path = dir.file("out.exr");
  const Status s = writeImage(path, img);
  ASSERT_TRUE(s.ok()) << s.error().describe();
  const Expected<Image> back = readImage(path);
  ASSERT_TRUE(back.ok()) << back.error().describe();
  expectBitExact(img, *back);
  EXPECT_EQ(directoryEntries(dir.path()), std::vector<std::string>{"out.exr"});
}

TEST(ImageIoTest, ExrHasFloatRgbChannelsAndZipCompression) {
  test::TempDir dir;
  const std::string path = dir.file("out.exr");
  ASSERT_TRUE(writeImage(path, testImage(8, 4, 0.1f, 10.0f)).ok());
  const std::string bytes = readBytes(path);
  ASSERT_GE(bytes.size(), 4u);
  EXPECT_EQ(bytes.substr(0, 4), std::string("\x76\x2f\x31\x01", 4));  // OpenEXR magic

  // Header attribute "compression": type "compression", size 1, value 3 = ZIP_COMPRESSION.
  const std::string compression("compression\0compression\0\x01\0\0\0", 28);
  const size_t at = bytes.find(compression);
  ASSERT_NE(at, std::string::npos);
  EXPECT_EQ(int(bytes[at + compression.size()]), 3);

  // Attribute "channels" (type chlist): per channel a name, int32 pixel type (2 = FLOAT), then
  // 12 more bytes; names sorted, list ended by an empty name.
  const std::string channels("channels\0chlist\0", 16);
  size_t p = bytes.find(channels);
  ASSERT_NE(p, std::string::npos);
  p += channels.size() + 4;  // skip the attribute size
  std::vector<std::string> names;
  while (p < bytes.size() && bytes[p] != '\0') {
    const std::string name(bytes.c_str() + p);
    p += name.size() + 1;
    int32_t type;
    std::memcpy(&type, bytes.data() + p, 4);
    EXPECT_EQ(type, 2) << name;
    p += 16;
    names.push_back(name);
  }
  EXPECT_EQ(names, (std::vector<std::string>{"B", "G", "R"}));
}

TEST(ImageIoTest, PfmRoundTripIsBitExactAndKeepsTheTopRowOnTop) {
  test::TempDir dir;
  Image img = testImage(5, 3, 1e-3f, 1e3f);
  img.at(4, 2) = glm::vec3(-2.0f, std::numeric_limits<float>::denorm_min(), 0.0f);
  const std::string path = dir.file("out.pfm");
  ASSERT_TRUE(writeImage(path, img).ok());

  // The file: header, then rows from the bottom of the image: its first pixel is (0, h - 1).
  const std::string bytes = readBytes(path);
  const std::string header = "PF\n5 3\n-1.0\n";
  ASSERT_EQ(bytes.size(), header.size() + 5 * 3 * 12);
  EXPECT_EQ(bytes.substr(0, header.size()), header);
  float first[3];
  std::memcpy(first, bytes.data() + header.size(), sizeof(first));  // little-endian host
  EXPECT_TRUE(sameBits(first[0], img.at(0, 2).x));
  EXPECT_TRUE(sameBits(first[1], img.at(0, 2).y));
  EXPECT_TRUE(sameBits(first[2], img.at(0, 2).z));

  const Expected<Image> back = readImage(path);
  ASSERT_TRUE(back.ok()) << back.error().describe();
  expectBitExact(img, *back);
}

TEST(ImageIoTest, PfmReadsBigEndianAndGreyscale) {
  test::TempDir dir;
  auto be = [](float v) {
    const uint32_t bits = std::bit_cast<uint32_t>(v);
    return std::string{char(bits >> 24), char(bits >> 16), char(bits >> 8), char(bits)};
  };
  // Big endian (positive scale), 1x2 RGB: the bottom row comes first in the file.
  std::string rgb = "PF\n1 2\n1.0\n";
  for (float v : {1.0f, 2.0f, 3.0f, 4.0f, 5.0f, 6.0f}) rgb += be(v);
  Expected<Image> a = readImage(dir.write("be.pfm", rgb));
  ASSERT_TRUE(a.ok()) << a.error().describe();
  ASSERT_EQ(a->width, 1);
  ASSERT_EQ(a->height, 2);
  EXPECT_EQ(a->at(0, 1), glm::vec3(1.0f, 2.0f, 3.0f));
  EXPECT_EQ(a->at(0, 0), glm::vec3(4.0f, 5.0f, 6.0f));

  // Greyscale "Pf", little endian, header fields separated by spaces.
  std::string grey = "Pf 2 1 -1\n";
  for (float v : {0.25f, 8.0f}) {
    char b[4];
    std::memcpy(b, &v, 4);
    grey.append(b, 4);
  }
  Expected<Image> g = readImage(dir.write("grey.pfm", grey));
  ASSERT_TRUE(g.ok()) << g.error().describe();
  EXPECT_EQ(g->at(0, 0), glm::vec3(0.25f));
  EXPECT_EQ(g->at(1, 0), glm::vec3(8.0f));
}

TEST(ImageIoTest, MalformedPfmNamesTheFileAndTheProblem) {
  test::TempDir dir;
  struct Case {
    const char* name;
    std::string contents;
    const char* expected;
  };
  const Case cases[] = {
      {"magic.pfm", "P6\n1 1\n255\n...", "not a PFM file"},
      {"size.pfm", "PF\n0 1\n-1.0\n", "bad image size"},
      {"scale.pfm", "PF\n1 1\nabc\n", "bad scale"},
      {"short.pfm", "PF\n2 2\n-1.0\n" + std::string(20, '\0'), "truncated"},
      {"empty.pfm", "", "not a PFM file"},
  };
  for (const Case& c : cases) {
    const std::string path = dir.write(c.name, c.contents);
    const Expected<Image> r = readImage(path);
    ASSERT_FALSE(r.ok()) << c.name;
    EXPECT_EQ(r.error().file, path);
    EXPECT_NE(r.error().describe().find(c.expected), std::string::npos) << r.error().describe();
    EXPECT_NE(r.error().describe().find(path), std::string::npos);
  }
}

TEST(ImageIoTest, HdrRoundTripWithinRgbePrecision) {
  test::TempDir dir;
  Image img = testImage(19, 11, 1e-4f, 1e4f);
  img.at(0, 0) = glm::vec3(0.0f);
  const std::string path = dir.file("out.hdr");
  ASSERT_TRUE(writeImage(path, img).ok());
  EXPECT_EQ(readBytes(path).substr(0, 2), "#?");  // Radiance header
  const Expected<Image> back = readImage(path);
  ASSERT_TRUE(back.ok()) << back.error().describe();
  ASSERT_EQ(back->width, img.width);
  ASSERT_EQ(back->height, img.height);
  // RGBE shares one exponent per pixel: each channel is good to 1/256 of the largest one.
  for (int y = 0; y < img.height; ++y) {
    for (int x = 0; x < img.width; ++x) {
      const glm::vec3 a = img.at(x, y), b = back->at(x, y);
      const float tolerance = std::max({a.x, a.y, a.z}) / 128.0f;
      for (int c = 0; c < 3; ++c) ASSERT_NEAR(b[c], a[c], tolerance) << x << "," << y;
    }
  }
  EXPECT_EQ(back->at(0, 0), glm::vec3(0.0f));
}

TEST(ImageIoTest, HdrWriteSanitisesWhatRgbeCannotHold) {
  test::TempDir dir;
  Image img(3, 1);
  img.pixels = {glm::vec3(std::numeric_limits<float>::quiet_NaN(), 1.0f, -2.0f),
                glm::vec3(std::numeric_limits<float>::infinity()), glm::vec3(0.5f)};
  const std::string path = dir.file("odd.hdr");
  ASSERT_TRUE(writeImage(path, img).ok());
  const Expected<Image> back = readImage(path);
  ASSERT_TRUE(back.ok()) << back.error().describe();
  EXPECT_EQ(back->pixels[0].x, 0.0f);
  EXPECT_NEAR(back->pixels[0].y, 1.0f, 0.01f);
  EXPECT_EQ(back->pixels[0].z, 0.0f);
  EXPECT_TRUE(std::isfinite(back->pixels[1].x));
  EXPECT_GT(back->pixels[1].x, 1e37f);
  EXPECT_NEAR(back->pixels[2].x, 0.5f, 0.005f);
}

TEST(ImageIoTest, PngRoundTripWithinSrgbQuantisation) {
  test::TempDir dir;
  Image img = testImage(13, 9, 1e-3f, 20.0f);
  for (int x = 0; x < img.width; ++x) {  // top row bright, bottom row black
    img.at(x, 0) = glm::vec3(50.0f);
    img.at(x, img.height - 1) = glm::vec3(0.0f);
  }
  for (const ToneMapOperator op : {ToneMapOperator::kExposure, ToneMapOperator::kReinhard}) {
    ToneMapSettings settings;
    settings.op = op;
    const std::string path = dir.file("out.png");
    ASSERT_TRUE(writeImage(path, img, settings).ok());
    const Expected<Image> back = readImage(path);
    ASSERT_TRUE(back.ok()) << back.error().describe();
    ASSERT_EQ(back->width, img.width);
    ASSERT_EQ(back->height, img.height);
    // What comes back is the tone-mapped image, decoded to linear: the same 8-bit code, and
    // within half the largest sRGB step (decode(1) - decode(254/255) = 0.0089).
    const Image expected = toneMap(img, settings);
    for (size_t i = 0; i < img.pixels.size(); ++i) {
      for (int c = 0; c < 3; ++c) {
        ASSERT_EQ(encodeSrgb8(back->pixels[i][c]), encodeSrgb8(expected.pixels[i][c])) << i;
        ASSERT_NEAR(back->pixels[i][c], expected.pixels[i][c], 0.0045f) << i;
      }
    }
    EXPECT_GT(back->at(0, 0).x, 0.9f);
    EXPECT_EQ(back->at(0, img.height - 1), glm::vec3(0.0f));
  }
}

TEST(ImageIoTest, PngReadDecodesSrgbToLinear) {
  test::TempDir dir;
  // 8-bit, 2x2: rows from the top.
  const std::vector<uint16_t> s8 = {0, 188, 255, 10, 11, 128, 1, 2, 3, 254, 100, 50};
  Expected<Image> a = readImage(dir.write("eight.png", makePng(2, 2, 8, s8)));
  ASSERT_TRUE(a.ok()) << a.error().describe();
  ASSERT_EQ(a->width, 2);
  ASSERT_EQ(a->height, 2);
  for (int y = 0; y < 2; ++y) {
    for (int x = 0; x < 2; ++x) {
      for (int c = 0; c < 3; ++c) {
        const uint16_t code = s8[size_t((y * 2 + x) * 3 + c)];
        EXPECT_NEAR(a->at(x, y)[c], decodeSrgb(code / 255.0), 1e-6) << x << "," << y;
      }
    }
  }
  EXPECT_EQ(a->at(0, 0).x, 0.0f);
  EXPECT_EQ(a->at(0, 0).z, 1.0f);
  EXPECT_NEAR(a->at(0, 0).y, 0.5029, 1e-4);  // code 188

  // 16-bit samples keep their precision.
  const std::vector<uint16_t> s16 = {0, 32768, 65535, 1000, 20000, 65000};
  Expected<Image> b = readImage(dir.write("sixteen.png", makePng(2, 1, 16, s16)));
  ASSERT_TRUE(b.ok()) << b.error().describe();
  for (int i = 0; i < 6; ++i) {
    EXPECT_NEAR(b->pixels[size_t(i / 3)][i % 3], decodeSrgb(s16[size_t(i)] / 65535.0), 1e-6) << i;
  }
}

TEST(ImageIoTest, WriteToMissingDirectoryFailsAndLeavesNothing) {
  test::TempDir dir;
  for (const char* name : {"out.exr", "out.hdr", "out.pfm", "out.png"}) {
    const std::string path = (dir.path() / "missing" / name).string();
    const Status s = writeImage(path, testImage(4, 4, 0.1f, 1.0f));
    ASSERT_FALSE(s.ok()) << name;
    EXPECT_EQ(s.error().file, path);
    EXPECT_NE(s.error().describe().find(path), std::string::npos);
  }
  EXPECT_TRUE(directoryEntries(dir.path()).empty());
}

TEST(ImageIoTest, UnknownExtensionFailsNamingTheFile) {
  test::TempDir dir;
  const std::string path = dir.file("out.xyz");
  const Status s = writeImage(path, testImage(4, 4, 0.1f, 1.0f));
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().kind, ErrorKind::kInput);
  EXPECT_EQ(s.error().file, path);
  EXPECT_EQ(s.error().message, "unsupported image format '.xyz' (use .exr, .hdr, .pfm or .png)");
  EXPECT_TRUE(directoryEntries(dir.path()).empty());

  const Status no_ext = writeImage(dir.file("out"), testImage(4, 4, 0.1f, 1.0f));
  ASSERT_FALSE(no_ext.ok());
  EXPECT_EQ(no_ext.error().file, dir.file("out"));
  EXPECT_TRUE(directoryEntries(dir.path()).empty());

  const Expected<Image> r = readImage(dir.write("in.jpg", "whatever"));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().describe().find("'.jpg'"), std::string::npos);
}

TEST(ImageIoTest, FailedRenameLeavesNoTemporaryFile) {
  test::TempDir dir;
  // The target is an existing directory: every writer succeeds on the temporary file, then the
  // rename fails, and the temporary file must be gone.
  for (const char* name : {"a.exr", "a.hdr", "a.pfm", "a.png"}) {
    fs::create_directory(dir.path() / name);
    fs::create_directory(dir.path() / name / "keep");
    const Status s = writeImage(dir.file(name), testImage(4, 4, 0.1f, 1.0f));
    ASSERT_FALSE(s.ok()) << name;
    EXPECT_EQ(s.error().file, dir.file(name));
  }
  auto entries = directoryEntries(dir.path());
  std::sort(entries.begin(), entries.end());
  EXPECT_EQ(entries, (std::vector<std::string>{"a.exr", "a.hdr", "a.pfm", "a.png"}));
}

TEST(ImageIoTest, EmptyOrInconsistentImageFails) {
  test::TempDir dir;
  Image bad_count(4, 4);
  bad_count.pixels.pop_back();
  for (const Image& img : {Image(), Image(0, 3), bad_count}) {
    for (const char* name : {"e.exr", "e.hdr", "e.pfm", "e.png"}) {
      const Status s = writeImage(dir.file(name), img);
      ASSERT_FALSE(s.ok()) << name;
      EXPECT_EQ(s.error().file, dir.file(name));
    }
  }
  EXPECT_TRUE(directoryEntries(dir.path()).empty());
}

TEST(ImageIoTest, ReadErrorsNameTheFile) {
  test::TempDir dir;
  const std::string missing = dir.file("missing.exr");
  const Expected<Image> m = readImage(missing);
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.error().file, missing);
  EXPECT_NE(m.error().message.find("no such file"), std::string::npos);

  for (const char* name : {"junk.exr", "junk.hdr", "junk.png", "junk.pfm"}) {
    const std::string path = dir.write(name, "this is not an image at all, just some text\n");
    const Expected<Image> r = readImage(path);
    ASSERT_FALSE(r.ok()) << name;
    EXPECT_EQ(r.error().file, path);
    EXPECT_FALSE(r.error().message.empty());
  }

  // A truncated EXR (the first half of a valid one) is an error, not an exception or a crash.
  const std::string good = dir.file("good.exr");
  ASSERT_TRUE(writeImage(good, testImage(64, 64, 0.1f, 10.0f)).ok());
  const std::string bytes = readBytes(good);
  const std::string cut = dir.write("cut.exr", bytes.substr(0, bytes.size() / 2));
  const Expected<Image> c = readImage(cut);
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.error().file, cut);

  // A Radiance file named .png is refused rather than silently tone mapped by the decoder.
  const std::string hdr = dir.file("real.hdr");
  ASSERT_TRUE(writeImage(hdr, testImage(4, 4, 0.1f, 10.0f)).ok());
  const Expected<Image> p = readImage(dir.write("fake.png", readBytes(hdr)));
  ASSERT_FALSE(p.ok());
  EXPECT_NE(p.error().message.find("PNG"), std::string::npos);
  // And a PNG named .hdr likewise.
  const std::string png = dir.file("real.png");
  ASSERT_TRUE(writeImage(png, testImage(4, 4, 0.1f, 10.0f)).ok());
  EXPECT_FALSE(readImage(dir.write("fake.hdr", readBytes(png))).ok());
}

TEST(ImageIoTest, TruncatedHdrIsAnErrorNotAHang) {
  // stb_image 2.27 spins forever on a run count of 0, which reading past the end of a truncated
  // run-length encoded file yields; the reader must check the data first.
  test::TempDir dir;
  const std::string good = dir.file("good.hdr");
  ASSERT_TRUE(writeImage(good, testImage(40, 6, 0.01f, 100.0f)).ok());  // 40 wide: RLE
  const std::string bytes = readBytes(good);
  const size_t data_start = bytes.find("+X 40\n") + 6;
  ASSERT_LT(data_start, bytes.size());
  for (size_t cut = data_start; cut < bytes.size(); cut += 7) {
    const std::string path = dir.write("cut.hdr", bytes.substr(0, cut));
    const Expected<Image> r = readImage(path);
    ASSERT_FALSE(r.ok()) << cut;
    EXPECT_EQ(r.error().file, path);
    EXPECT_NE(r.error().message.find("truncated"), std::string::npos) << r.error().describe();
  }
  // A zero run count inside the data is corrupt, not an endless loop.
  std::string zero = bytes;
  zero[data_start + 4] = 0;
  const Expected<Image> z = readImage(dir.write("zero.hdr", zero));
  ASSERT_FALSE(z.ok());
  EXPECT_NE(z.error().describe().find("scan line 0"), std::string::npos) << z.error().describe();
}

TEST(ImageIoTest, ExtensionIsCaseInsensitive) {
  test::TempDir dir;
  const Image img = testImage(3, 2, 0.5f, 2.0f);
  const std::string path = dir.file("UPPER.EXR");
  ASSERT_TRUE(writeImage(path, img).ok());
  const Expected<Image> back = readImage(path);
  ASSERT_TRUE(back.ok()) << back.error().describe();
  expectBitExact(img, *back);
}

TEST(ImageIoTest, APngClaimingMorePixelsThanItsBytesHoldIsRefusedFromItsHeader) {
  // Found by fuzzing: 64 bytes whose header claims 16,777,216 x 12 pixels (2.4 GB decoded).
  test::TempDir dir;
  const std::string bytes(
      "\x89\x50\x4e\x47\x0d\x0a\x1a\x0a\x00\x00\x00\x0d\x49\x48\x44\x52\x01\x00\x00\x00\x00\x00\x00"
      "\x0c\x08\x02\x00\x00\x00\x22\x66\xd9\x14\x00\x00\x00\x45\x49\x48\x44\x52\x00\x09\x00\x06\x00"
      "\x00\x00\x04\x08\x02\x00\x91\x00\x00\x53\x1b\x21\x44\xae\x42\x60\x82\x4a",
      64);
  const std::string path = dir.write("claims.png", bytes);
  Expected<Image> img = readImage(path);
  ASSERT_FALSE(img.ok());
  EXPECT_EQ(img.error().file, path);
  // Its IHDR's CRC does not match either: the header walk refuses it as damaged before looking
  // at the size (image_decode_test has the size claim alone).
  EXPECT_EQ(img.error().message, "the file is damaged: chunk IHDR fails its CRC check")
      << img.error().describe();
}

TEST(ImageIoTest, AnExrAttributeLargerThanTheFileIsRefusedBeforeOpenExrReadsIt) {
  // Found by fuzzing: an attribute claiming 1.7 GB in a 530-byte file kept OpenEXR's header
  // reader busy for more than 10 s. The same fault is made here in a valid file: the size field
  // of its lineOrder attribute is raised past the end of the file.
  test::TempDir dir;
  Image image(4, 3);
  const std::string good = (dir.path() / "good.exr").string();
  ASSERT_TRUE(writeImage(good, image).ok());
  std::ifstream in(good, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string attribute("lineOrder\0lineOrder\0", 20);
  const size_t at = bytes.find(attribute);
  ASSERT_NE(at, std::string::npos);
  ASSERT_EQ(bytes[at + 20], 1);  // a one-byte attribute
  const std::string valid = dir.write("valid.exr", bytes);
  EXPECT_TRUE(readImage(valid).ok());
  bytes.replace(at + 20, 4, std::string("\x00\x69\x6e\x65", 4));  // 1,701,734,656 bytes
  const std::string path = dir.write("attribute.exr", bytes);
  Expected<Image> img = readImage(path);
  EXPECT_TRUE(test::errorNames(img, path, "attribute 'lineOrder'"));
  EXPECT_NE(img.error().message.find("runs past the end of the file"), std::string::npos)
      << img.error().describe();
  // A file cut inside its header.
  const std::string cut = dir.write("cut.exr", bytes.substr(0, at + 5));
  EXPECT_TRUE(test::errorNames(readImage(cut), cut, "the header ends early"));
}

}  // namespace
}  // namespace penumbra
