// Tone mapping of linear radiance to display values in [0, 1] (linear, before sRGB encoding).
// Two operators, as in Wallner sec. 3: a simple exposure function, and the global photographic
// operator of Reinhard et al. 2002 with the automatic key estimation of Reinhard, "Parameter
// estimation for photographic tone reproduction", JGT 7(1), 2002.
#pragma once

#include "penumbra/core/image.h"

#include <cstdint>

namespace penumbra {

enum class ToneMapOperator {
  kExposure,  // L_d = 1 - exp(-2^stops * L): simple exposure
  kReinhard,  // global photographic operator with automatic key and white point
};

struct ToneMapSettings {
  ToneMapOperator op = ToneMapOperator::kReinhard;
  float exposure_stops = 0.0f;  // multiplies radiance by 2^stops before either operator
  float key = -1.0f;            // Reinhard key value a; < 0 selects the automatic estimate
  float white = -1.0f;          // Reinhard L_white; < 0 selects the automatic estimate
};

// Relative luminance of linear sRGB / Rec. 709 primaries.
inline float luminance(const glm::vec3& c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }

// Reinhard 2002 (JGT) automatic key: a = 0.18 * 4^((2 log2 Lav - log2 Lmin - log2 Lmax) /
// (log2 Lmax - log2 Lmin)), from the log-average, minimum and maximum luminance.
float estimateKey(const Image& linear);

// Maps linear radiance to display-linear values in [0, 1].
Image toneMap(const Image& linear, const ToneMapSettings& settings);

// sRGB opto-electronic transfer function, 8-bit with rounding.
uint8_t encodeSrgb8(float display_linear);

}  // namespace penumbra
