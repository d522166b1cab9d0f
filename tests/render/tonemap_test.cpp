// Tone mapping: the exposure function, Reinhard et al. 2002 eq. 4 with the automatic key and
// white point of Reinhard 2002 (JGT) eqs. 4-5, and the sRGB transfer function (IEC 61966-2-1).
#include "penumbra/io/tonemap.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace penumbra {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

Image uniformImage(int w, int h, glm::vec3 c) {
  Image img(w, h);
  for (glm::vec3& p : img.pixels) p = c;
  return img;
}

// A grey image of `n` pixels: the first `n_low` at `low`, the rest at `high`.
Image twoLevelImage(int n, int n_low, float low, float high) {
  Image img(n, 1);
  for (int i = 0; i < n; ++i) img.pixels[size_t(i)] = glm::vec3(i < n_low ? low : high);
  return img;
}

ToneMapSettings reinhard(float key = -1.0f, float white = -1.0f, float stops = 0.0f) {
  ToneMapSettings s;
  s.op = ToneMapOperator::kReinhard;
  s.key = key;
  s.white = white;
  s.exposure_stops = stops;
  return s;
}

ToneMapSettings exposure(float stops) {
  ToneMapSettings s;
  s.op = ToneMapOperator::kExposure;
  s.exposure_stops = stops;
  return s;
}

void expectAllFiniteInUnitRange(const Image& img) {
  for (const glm::vec3& p : img.pixels) {
    for (int c = 0; c < 3; ++c) {
      ASSERT_TRUE(std::isfinite(p[c]));
      ASSERT_GE(p[c], 0.0f);
      ASSERT_LE(p[c], 1.0f);
    }
  }
}

// IEC 61966-2-1 inverse transfer function, to check encodeSrgb8 against.
double decodeSrgb(double v) {
  return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

TEST(ToneMapTest, LuminanceUsesRec709Weights) {
  EXPECT_FLOAT_EQ(luminance(glm::vec3(1.0f)), 1.0f);
  EXPECT_FLOAT_EQ(luminance(glm::vec3(1.0f, 0.0f, 0.0f)), 0.2126f);
  EXPECT_FLOAT_EQ(luminance(glm::vec3(0.0f, 1.0f, 0.0f)), 0.7152f);
  EXPECT_FLOAT_EQ(luminance(glm::vec3(0.0f, 0.0f, 1.0f)), 0.0722f);
}

TEST(ToneMapTest, ExposureOperatorIsOneMinusExp) {
  Image img(3, 1);
  img.pixels = {glm::vec3(0.0f), glm::vec3(0.5f, 1.0f, 2.0f), glm::vec3(100.0f)};
  const Image out = toneMap(img, exposure(0.0f));
  EXPECT_EQ(out.width, 3);
  EXPECT_EQ(out.height, 1);
  EXPECT_EQ(out.pixels[0], glm::vec3(0.0f));
  EXPECT_NEAR(out.pixels[1].x, 1.0 - std::exp(-0.5), 1e-7);
  EXPECT_NEAR(out.pixels[1].y, 1.0 - std::exp(-1.0), 1e-7);
  EXPECT_NEAR(out.pixels[1].z, 1.0 - std::exp(-2.0), 1e-7);
  EXPECT_FLOAT_EQ(out.pixels[2].x, 1.0f);
  // -1.5 stops scales radiance by 2^-1.5.
  const Image darker = toneMap(img, exposure(-1.5f));
  EXPECT_NEAR(darker.pixels[1].y, 1.0 - std::exp(-std::exp2(-1.5)), 1e-7);
}

TEST(ToneMapTest, OneStopEqualsDoublingTheInput) {
  Image img(16, 4);
  for (size_t i = 0; i < img.pixels.size(); ++i) {
    const float v = 0.01f * float(i * i);
    img.pixels[i] = glm::vec3(v, 0.5f * v, 2.0f * v);
  }
  Image doubled = img;
  for (glm::vec3& p : doubled.pixels) p *= 2.0f;

  // Powers of two are exact, so the exposure function gives identical bits.
  const Image a = toneMap(img, exposure(1.0f));
  const Image b = toneMap(doubled, exposure(0.0f));
  for (size_t i = 0; i < a.pixels.size(); ++i) EXPECT_EQ(a.pixels[i], b.pixels[i]) << i;

  // The photographic operator is scale-invariant (it divides by the log-average), so there
  // exposure scales the key instead: +1 stop is the doubled key, and brighter than 0 stops.
  for (const ToneMapSettings& s : {reinhard(0.3f, 2.0f), reinhard(0.1f, 1e30f)}) {
    ToneMapSettings plus_one = s;
    plus_one.exposure_stops = 1.0f;
    ToneMapSettings doubled_key = s;
    doubled_key.key = 2.0f * s.key;
    const Image c = toneMap(img, plus_one);
    const Image d = toneMap(img, doubled_key);
    const Image e = toneMap(doubled, s);  // input scale alone changes nothing
    const Image f = toneMap(img, s);
    for (size_t i = 0; i < c.pixels.size(); ++i) {
      for (int k = 0; k < 3; ++k) {
        EXPECT_NEAR(c.pixels[i][k], d.pixels[i][k], 1e-6) << i;
        EXPECT_NEAR(e.pixels[i][k], f.pixels[i][k], 1e-6) << i;
        EXPECT_GE(c.pixels[i][k], f.pixels[i][k]) << i;
      }
    }
  }
}

// With L_white -> infinity, eq. 4 is L / (1 + L); a uniform image has L_av = L_w, so every pixel
// is scaled to exactly the key a and maps to a / (1 + a).
TEST(ToneMapTest, ReinhardUniformImageMapsToKeyOverOnePlusKey) {
  for (float radiance : {1e-4f, 0.37f, 1.0f, 250.0f}) {
    for (float key : {0.09f, 0.18f, 0.72f}) {
      const Image out = toneMap(uniformImage(5, 3, glm::vec3(radiance)), reinhard(key, kInf));
      const double expected = double(key) / (1.0 + double(key));
      for (const glm::vec3& p : out.pixels) {
        EXPECT_NEAR(p.x, expected, 1e-6) << radiance << " " << key;
        EXPECT_NEAR(p.y, expected, 1e-6);
        EXPECT_NEAR(p.z, expected, 1e-6);
      }
    }
    // The automatic key of a uniform image is 0.18 (its average is midway in a zero range).
    const Image automatic = toneMap(uniformImage(5, 3, glm::vec3(radiance)), reinhard(-1.0f, kInf));
    EXPECT_NEAR(automatic.pixels[0].y, 0.18 / 1.18, 1e-6);
  }
}

TEST(ToneMapTest, ReinhardFollowsEquationFour) {
  // Two pixels, L_w = 1 and 4: L_av = 2, so with key 0.18 the scaled values are 0.09 and 0.36.
  const Image img = twoLevelImage(2, 1, 1.0f, 4.0f);
  const Image no_white = toneMap(img, reinhard(0.18f, kInf));
  EXPECT_NEAR(no_white.pixels[0].x, 0.09 / 1.09, 1e-6);
  EXPECT_NEAR(no_white.pixels[1].x, 0.36 / 1.36, 1e-6);
  // L_white = 1 makes eq. 4 the identity: L (1 + L) / (1 + L) = L.
  const Image unit_white = toneMap(img, reinhard(0.18f, 1.0f));
  EXPECT_NEAR(unit_white.pixels[0].x, 0.09, 1e-6);
  EXPECT_NEAR(unit_white.pixels[1].x, 0.36, 1e-6);
  // A pixel at L = L_white maps to exactly 1 (the white point).
  const Image at_white = toneMap(img, reinhard(0.18f, 0.36f));
  EXPECT_NEAR(at_white.pixels[1].x, 1.0, 1e-6);
  EXPECT_NEAR(at_white.pixels[0].x, 0.09 * (1.0 + 0.09 / (0.36 * 0.36)) / 1.09, 1e-6);
}

TEST(ToneMapTest, ReinhardKeepsHueBelowClipping) {
  Image img(2, 1);
  img.pixels = {glm::vec3(0.2f, 0.5f, 0.1f), glm::vec3(3.0f, 1.0f, 0.5f)};
  const Image out = toneMap(img, reinhard(0.18f, kInf));
  for (size_t i = 0; i < 2; ++i) {
    const glm::vec3 in = img.pixels[i];
    const glm::vec3 o = out.pixels[i];
    ASSERT_LT(std::max({o.x, o.y, o.z}), 1.0f);
    EXPECT_NEAR(o.x / o.y, in.x / in.y, 1e-5);
    EXPECT_NEAR(o.z / o.y, in.z / in.y, 1e-5);
  }
}

TEST(ToneMapTest, ReinhardIsMonotonicInInput) {
  // A ramp over 12 decades (so the automatic white point clips nothing but the very top).
  Image img(512, 1);
  for (int x = 0; x < img.width; ++x) {
    img.pixels[size_t(x)] = glm::vec3(float(std::pow(10.0, -6.0 + 12.0 * x / (img.width - 1))));
  }
  for (const ToneMapSettings& s : {reinhard(), reinhard(0.18f, kInf), exposure(0.0f)}) {
    const Image out = toneMap(img, s);
    expectAllFiniteInUnitRange(out);
    for (int x = 1; x < img.width; ++x) {
      const float prev = out.pixels[size_t(x - 1)].y;
      const float cur = out.pixels[size_t(x)].y;
      EXPECT_GE(cur, prev) << x;
      if (cur < 1.0f && prev > 0.0f && prev < 0.999f) {
        EXPECT_GT(cur, prev) << x;
      }
    }
  }
}

TEST(ToneMapTest, AutomaticKeyIsMiddleGreyWhenAverageIsMidwayInLog2) {
  // Half at 1, half at 4: log2 L_av = 1, midway between log2 L_min = 0 and log2 L_max = 2.
  EXPECT_NEAR(estimateKey(twoLevelImage(100, 50, 1.0f, 4.0f)), 0.18f, 1e-6);
  EXPECT_NEAR(estimateKey(twoLevelImage(1000, 500, 0.001f, 1000.0f)), 0.18f, 1e-6);
  // Uniform (zero range) and all-black images: 0.18, finite.
  EXPECT_NEAR(estimateKey(uniformImage(4, 4, glm::vec3(3.0f))), 0.18f, 1e-6);
  EXPECT_NEAR(estimateKey(Image(4, 4)), 0.18f, 1e-6);
}

TEST(ToneMapTest, AutomaticKeyFollowsJgtEquationFour) {
  // 90% at 1 and 10% at 16: log2 L_av = 0.4, range 0..4, exponent (0.8 - 4) / 4 = -0.8. The
  // image is mostly dark (low key), so a < 0.18.
  const float low_key = estimateKey(twoLevelImage(100, 90, 1.0f, 16.0f));
  EXPECT_NEAR(low_key, 0.18 * std::pow(4.0, -0.8), 1e-6);
  // Mirror image, mostly bright (high key): exponent +0.8.
  const float high_key = estimateKey(twoLevelImage(100, 10, 1.0f, 16.0f));
  EXPECT_NEAR(high_key, 0.18 * std::pow(4.0, 0.8), 1e-6);
  // Independent of the overall scale of the radiance.
  EXPECT_NEAR(estimateKey(twoLevelImage(100, 90, 1e-3f, 16e-3f)), low_key, 1e-6);
}

TEST(ToneMapTest, AutomaticKeyIgnoresOutliers) {
  // One firefly among 1000 pixels must not change the key much: the 1st and 99th percentiles
  // bound the range. (With the plain min and max the exponent would be about -0.9, a = 0.05.)
  Image img = twoLevelImage(1000, 500, 1.0f, 4.0f);
  img.pixels[999] = glm::vec3(1e6f);
  EXPECT_NEAR(estimateKey(img), 0.18f, 0.01f);
}

TEST(ToneMapTest, AutomaticWhitePointFollowsJgtEquationFive) {
  // Half at 1, half at 2^10: range 10 zones, L_white = 1.5 * 2^(10 - 5) = 48; key 0.18.
  const Image img = twoLevelImage(200, 100, 1.0f, 1024.0f);
  const Image automatic = toneMap(img, reinhard());
  const Image explicit_params = toneMap(img, reinhard(0.18f, 48.0f));
  for (size_t i = 0; i < img.pixels.size(); ++i) {
    EXPECT_NEAR(automatic.pixels[i].x, explicit_params.pixels[i].x, 1e-6) << i;
  }
  // L_av = 2^5; the bright pixels scale to L = 0.18 * 32.
  const double l = 0.18 * 32.0;
  EXPECT_NEAR(automatic.pixels[150].x, l * (1.0 + l / (48.0 * 48.0)) / (1.0 + l), 1e-6);
}

TEST(ToneMapTest, BlackImageStaysBlack) {
  for (const ToneMapSettings& s : {reinhard(), reinhard(0.18f, 1.0f), exposure(3.0f)}) {
    const Image out = toneMap(Image(7, 5), s);
    ASSERT_EQ(out.pixels.size(), 35u);
    for (const glm::vec3& p : out.pixels) EXPECT_EQ(p, glm::vec3(0.0f));
  }
}

TEST(ToneMapTest, NonFiniteInputGivesFiniteOutputAndCountsAsBlack) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  Image bad(4, 2);
  bad.pixels = {glm::vec3(nan),
                glm::vec3(1.0f, nan, 0.5f),
                glm::vec3(kInf),
                glm::vec3(-kInf, 2.0f, 1.0f),
                glm::vec3(0.5f),
                glm::vec3(2.0f),
                glm::vec3(0.1f, 0.2f, 0.3f),
                glm::vec3(8.0f)};
  Image clean = bad;
  for (glm::vec3& p : clean.pixels) {
    for (int c = 0; c < 3; ++c) {
      if (!std::isfinite(p[c])) p[c] = 0.0f;
    }
  }
  for (const ToneMapSettings& s : {reinhard(), reinhard(0.18f, kInf), exposure(0.0f)}) {
    const Image out = toneMap(bad, s);
    expectAllFiniteInUnitRange(out);
    const Image expected = toneMap(clean, s);
    for (size_t i = 0; i < out.pixels.size(); ++i) EXPECT_EQ(out.pixels[i], expected.pixels[i]);
  }
  // An image of nothing but NaN is black.
  const Image all_nan = toneMap(uniformImage(3, 3, glm::vec3(nan)), reinhard());
  for (const glm::vec3& p : all_nan.pixels) EXPECT_EQ(p, glm::vec3(0.0f));
  EXPECT_TRUE(std::isfinite(estimateKey(bad)));
}

TEST(ToneMapTest, ExtremeValuesDoNotOverflow) {
  Image img(3, 1);
  img.pixels = {glm::vec3(std::numeric_limits<float>::max()), glm::vec3(1e-40f), glm::vec3(1.0f)};
  for (const ToneMapSettings& s :
       {reinhard(), reinhard(0.18f, 0.0f), reinhard(-1.0f, -1.0f, 200.0f), exposure(200.0f),
        exposure(-200.0f)}) {
    expectAllFiniteInUnitRange(toneMap(img, s));
  }
}

TEST(ToneMapTest, SrgbEncodeKnownValues) {
  EXPECT_EQ(encodeSrgb8(0.0f), 0);
  EXPECT_EQ(encodeSrgb8(1.0f), 255);
  EXPECT_EQ(encodeSrgb8(0.5f), 188);   // 1.055 * 0.5^(1/2.4) - 0.055 = 0.7354 -> 187.5
  EXPECT_EQ(encodeSrgb8(0.18f), 118);  // middle grey
  // The two segments meet at 0.0031308 (12.92 * 0.0031308 = 0.04045 -> 10.3).
  EXPECT_EQ(encodeSrgb8(0.0031308f), 10);
  EXPECT_EQ(encodeSrgb8(std::nextafter(0.0031308f, 0.0f)), 10);
  EXPECT_EQ(encodeSrgb8(std::nextafter(0.0031308f, 1.0f)), 10);
  EXPECT_EQ(encodeSrgb8(0.001f), 3);  // linear segment: 12.92 * 0.001 * 255 = 3.29
  // Out of range and non-finite input clamps, never wraps.
  EXPECT_EQ(encodeSrgb8(-0.5f), 0);
  EXPECT_EQ(encodeSrgb8(7.0f), 255);
  EXPECT_EQ(encodeSrgb8(std::numeric_limits<float>::quiet_NaN()), 0);
  EXPECT_EQ(encodeSrgb8(-kInf), 0);
  EXPECT_EQ(encodeSrgb8(kInf), 255);
}

TEST(ToneMapTest, SrgbEncodeInvertsTheStandardDecode) {
  // Every 8-bit code decodes (IEC 61966-2-1) to a linear value that encodes back to itself.
  for (int k = 0; k < 256; ++k) EXPECT_EQ(encodeSrgb8(float(decodeSrgb(k / 255.0))), k) << k;
  // And the encoding is monotonic.
  int prev = 0;
  for (int i = 0; i <= 10000; ++i) {
    const int code = encodeSrgb8(float(i) / 10000.0f);
    EXPECT_GE(code, prev);
    prev = code;
  }
}

}  // namespace
}  // namespace penumbra
