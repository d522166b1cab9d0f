// Tone mapping: the exposure function and the global photographic operator of
//   [RSSF02] E. Reinhard, M. Stark, P. Shirley, J. Ferwerda, "Photographic tone reproduction for
//            digital images", ACM TOG 21(3) (SIGGRAPH 2002), sec. 3.1, eqs. 1-4;
// with the automatic parameters of
//   [R02]    E. Reinhard, "Parameter estimation for photographic tone reproduction", Journal of
//            Graphics Tools 7(1), 2002, eqs. 4 (key) and 5 (white point).
// The sRGB transfer function is the one of IEC 61966-2-1:1999.
//
// All arithmetic on radiance is done in double so that 2^exposure_stops times a large float
// cannot overflow to infinity on the way.
#include "penumbra/io/tonemap.h"

#include "penumbra/core/parallel.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace penumbra {

namespace {

constexpr double kMiddleGrey = 0.18;  // [RSSF02] sec. 3.1: the "normal" key value
constexpr double kPercentile = 0.01;  // [R02] sec. 3: ignore the darkest and brightest 1%
constexpr double kMaxStops = 512.0;   // |exposure_stops| is clamped so 2^stops stays finite
constexpr size_t kPixelGrain = 4096;  // pixels per parallel task

// A display cannot show negative or non-finite radiance: such channel values count as 0.
double sanitize(float v) {
  return std::isfinite(v) && v > 0.0f ? double(v) : 0.0;
}

glm::dvec3 sanitize(const glm::vec3& c) {
  return glm::dvec3(sanitize(c.x), sanitize(c.y), sanitize(c.z));
}

// Clamps to [0, 1]; NaN becomes 0.
double clampUnit(double v) {
  return v > 0.0 ? std::min(v, 1.0) : 0.0;
}

double exposureScale(float stops) {
  if (!std::isfinite(stops)) return 1.0;
  return std::exp2(std::clamp(double(stops), -kMaxStops, kMaxStops));
}

// What [R02] needs to know about an image's luminance L_w (after the exposure scale), over the
// pixels with L_w > 0.
struct LuminanceStats {
  size_t positive = 0;       // number of pixels with L_w > 0
  double log_average = 0.0;  // L_av = exp(mean log L_w), [RSSF02] eq. 1
  double log2_min = 0.0;     // log2 of the 1st percentile of L_w ([R02]: robust L_min)
  double log2_max = 0.0;     // log2 of the 99th percentile of L_w ([R02]: robust L_max)
};

// [RSSF02] eq. 1 averages log(delta + L_w) over all pixels, delta only guarding log(0). We
// average over the pixels with L_w > 0 instead (as delta -> 0 with black pixels left out): in a
// rendering, black pixels are background that no light path reached, not dark scene tones, and
// counting them at log(delta) would drag L_av by an amount set by the arbitrary delta (an object
// against black would burn out to white). For images without black pixels this is eq. 1 with
// delta = 0.
LuminanceStats luminanceStats(const Image& image, double scale) {
  std::vector<double> log2_l;
  log2_l.reserve(image.pixels.size());
  for (const glm::vec3& c : image.pixels) {
    const double l = scale * luminance(glm::dvec3(sanitize(c)));
    if (l > 0.0) log2_l.push_back(std::log2(l));
  }
  LuminanceStats s;
  s.positive = log2_l.size();
  if (s.positive == 0) return s;

  double sum = 0.0;
  for (double v : log2_l) sum += v;
  s.log_average = std::exp2(sum / double(s.positive));

  // Nearest-rank percentiles, symmetric so that a two-valued image has its two values as range.
  const size_t lo = size_t(kPercentile * double(s.positive - 1));
  const size_t hi = s.positive - 1 - lo;
  std::nth_element(log2_l.begin(), log2_l.begin() + std::ptrdiff_t(lo), log2_l.end());
  s.log2_min = log2_l[lo];
  std::nth_element(log2_l.begin(), log2_l.begin() + std::ptrdiff_t(hi), log2_l.end());
  s.log2_max = log2_l[hi];
  return s;
}

// [R02] eq. 4: a = 0.18 * 4^((2 log2 L_av - log2 L_min - log2 L_max) / (log2 L_max - log2 L_min)).
// The exponent lies in [-1, 1] when L_av is within [L_min, L_max], giving the key range 0.045 to
// 0.72 of [RSSF02] sec. 3.1; it is clamped there because the trimmed L_min, L_max need not
// bracket L_av. A zero range (a uniform image) has its average midway: a = 0.18.
double keyFromStats(const LuminanceStats& s) {
  if (s.positive == 0) return kMiddleGrey;
  const double range = s.log2_max - s.log2_min;
  if (!(range > 0.0)) return kMiddleGrey;
  const double t = (2.0 * std::log2(s.log_average) - s.log2_min - s.log2_max) / range;
  return kMiddleGrey * std::pow(4.0, std::clamp(t, -1.0, 1.0));
}

// [R02] eq. 5: L_white = 1.5 * 2^(log2 L_max - log2 L_min - 5), in units of the scaled luminance
// L of [RSSF02] eq. 2. Images spanning fewer than about 5 zones get a white point below their
// brightest values and burn out a little, as in a photographic print. We use the same 1st/99th
// percentile range as for the key so that a few outliers (Monte Carlo fireflies) cannot move it.
double whiteFromStats(const LuminanceStats& s) {
  return 1.5 * std::exp2(s.log2_max - s.log2_min - 5.0);
}

Image exposureOperator(const Image& linear, double scale) {
  Image out(linear.width, linear.height);
  parallelRange(linear.pixels.size(), kPixelGrain, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const glm::dvec3 c = scale * sanitize(linear.pixels[i]);
      out.pixels[i] =
          glm::vec3(float(clampUnit(-std::expm1(-c.x))), float(clampUnit(-std::expm1(-c.y))),
                    float(clampUnit(-std::expm1(-c.z))));
    }
  });
  return out;
}

Image reinhardOperator(const Image& linear, const ToneMapSettings& settings, double scale) {
  Image out(linear.width, linear.height);  // black
  const LuminanceStats stats = luminanceStats(linear, scale);
  if (stats.positive == 0) return out;

  const double key = settings.key >= 0.0f && std::isfinite(settings.key) ? double(settings.key)
                                                                         : keyFromStats(stats);
  const double white = settings.white >= 0.0f && !std::isnan(settings.white)
                           ? double(settings.white)
                           : whiteFromStats(stats);
  const double inv_white2 = 1.0 / (white * white);  // 0 for an infinite white point
  // The operator divides by the log-average, which cancels any scale of the input; exposure
  // therefore scales the key, so that +1 stop brightens under either operator.
  const double key_over_average = key * scale / stats.log_average;

  parallelRange(linear.pixels.size(), kPixelGrain, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const glm::dvec3 c = scale * sanitize(linear.pixels[i]);
      const double l_w = luminance(c);
      if (!(l_w > 0.0)) continue;                                 // stays black
      const double l = key_over_average * l_w;                    // [RSSF02] eq. 2
      const double l_d = l * (1.0 + l * inv_white2) / (1.0 + l);  // [RSSF02] eq. 4
      // Colour follows luminance, which keeps hue and saturation; a channel pushed past 1 clips.
      const double ratio = l_d / l_w;
      auto channel = [ratio](double v) { return v > 0.0 ? float(clampUnit(v * ratio)) : 0.0f; };
      out.pixels[i] = glm::vec3(channel(c.x), channel(c.y), channel(c.z));
    }
  });
  return out;
}

}  // namespace

float estimateKey(const Image& linear) {
  return float(keyFromStats(luminanceStats(linear, 1.0)));
}

Image toneMap(const Image& linear, const ToneMapSettings& settings) {
  const double scale = exposureScale(settings.exposure_stops);
  switch (settings.op) {
    case ToneMapOperator::kExposure:
      return exposureOperator(linear, scale);
    case ToneMapOperator::kReinhard:
      return reinhardOperator(linear, settings, scale);
    case ToneMapOperator::kNone: {
      Image out = linear;
      for (glm::vec3& c : out.pixels) {
        for (int k = 0; k < 3; ++k) c[k] = c[k] > 0.0f ? std::min(c[k], 1.0f) : 0.0f;  // NaN: 0
      }
      return out;
    }
  }
  return reinhardOperator(linear, settings, scale);
}

uint8_t encodeSrgb8(float display_linear) {
  if (!(display_linear > 0.0f)) return 0;  // also NaN
  if (display_linear >= 1.0f) return 255;
  // IEC 61966-2-1:1999 sec. 5.2: linear segment below 0.0031308, else 1.055 v^(1/2.4) - 0.055.
  const double v = display_linear;
  const double encoded = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
  return uint8_t(std::lround(std::clamp(encoded, 0.0, 1.0) * 255.0));
}

}  // namespace penumbra
