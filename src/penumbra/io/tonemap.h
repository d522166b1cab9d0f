// Tone mapping of linear radiance to display values in [0, 1] (linear, before sRGB encoding).
// Two operators, as in Wallner sec. 3: a simple exposure function, and the global photographic
// operator of Reinhard et al. 2002 with the automatic key estimation of Reinhard, "Parameter
// estimation for photographic tone reproduction", JGT 7(1), 2002.
#pragma once

#include "penumbra/core/color.h"
#include "penumbra/core/image.h"

#include <cstdint>

namespace penumbra {

enum class ToneMapOperator {
  kExposure,  // L_d = 1 - exp(-2^stops * L): simple exposure
  kReinhard,  // global photographic operator with automatic key and white point
  kNone,      // the values are display-linear already (plots, false colour): clamped to [0, 1]
};

struct ToneMapSettings {
  ToneMapOperator op = ToneMapOperator::kReinhard;
  // kExposure: multiplies radiance by 2^stops. kReinhard: multiplies the key by 2^stops (the
  // operator divides by the log-average luminance, so scaling radiance would cancel out).
  float exposure_stops = 0.0f;
  float key = -1.0f;    // Reinhard key value a; < 0 (or NaN) selects the automatic estimate
  float white = -1.0f;  // Reinhard L_white, in units of the scaled luminance a L_w / L_av;
                        // < 0 (or NaN) selects the automatic estimate, +inf means no burn-out
};

// Reinhard 2002 (JGT) automatic key: a = 0.18 * 4^((2 log2 Lav - log2 Lmin - log2 Lmax) /
// (log2 Lmax - log2 Lmin)), from the log-average, minimum and maximum luminance. Lmin and Lmax
// are the 1st and 99th percentiles over the pixels with L > 0, and the result lies in
// [0.045, 0.72]; 0.18 for an image that is black or uniform.
float estimateKey(const Image& linear);

// Maps linear radiance to display-linear values in [0, 1]. Negative and non-finite channel
// values count as 0; the output is always finite.
Image toneMap(const Image& linear, const ToneMapSettings& settings);

// sRGB opto-electronic transfer function (IEC 61966-2-1), 8-bit with rounding; input outside
// [0, 1] clamps (NaN gives 0).
uint8_t encodeSrgb8(float display_linear);

}  // namespace penumbra
