#include "penumbra/scene/media.h"

#include "penumbra/kernels/dipole.h"

#include <fmt/format.h>

#include <array>
#include <cmath>

namespace penumbra {

namespace {

struct Measured {
  const char* name;
  double sigma_s[3];  // mm^-1
  double sigma_a[3];  // mm^-1
};

// Jensen et al. 2001, Fig. 5 (also ../shared/data/README.md).
constexpr std::array<Measured, 12> kMeasured = {{
    {"apple", {2.29, 2.39, 1.97}, {0.0030, 0.0034, 0.046}},
    {"chicken1", {0.15, 0.21, 0.38}, {0.015, 0.077, 0.19}},
    {"chicken2", {0.19, 0.25, 0.32}, {0.018, 0.088, 0.20}},
    {"cream", {7.38, 5.47, 3.15}, {0.0002, 0.0028, 0.0163}},
    {"ketchup", {0.18, 0.07, 0.03}, {0.061, 0.97, 1.45}},
    {"marble", {2.19, 2.62, 3.00}, {0.0021, 0.0041, 0.0071}},
    {"potato", {0.68, 0.70, 0.55}, {0.0024, 0.0090, 0.12}},
    {"skimmilk", {0.70, 1.22, 1.90}, {0.0014, 0.0025, 0.0142}},
    {"skin1", {0.74, 0.88, 1.01}, {0.032, 0.17, 0.48}},
    {"skin2", {1.09, 1.59, 1.79}, {0.013, 0.070, 0.145}},
    {"spectralon", {11.6, 20.4, 14.9}, {0.00, 0.00, 0.00}},
    {"wholemilk", {2.55, 3.21, 3.77}, {0.0011, 0.0024, 0.014}},
}};

constexpr std::array<const char*, 12> kNames = {"apple",   "chicken1", "chicken2",   "cream",
                                                "ketchup", "marble",   "potato",     "skimmilk",
                                                "skin1",   "skin2",    "spectralon", "wholemilk"};

constexpr double kMetresPerMm = 1e-3;
constexpr double kJensenEta = 1.3;

}  // namespace

std::optional<Subsurface> subsurfacePreset(std::string_view name) {
  for (const Measured& m : kMeasured) {
    if (name != m.name) continue;
    Subsurface s;
    s.sigma_s_prime = glm::dvec3(m.sigma_s[0], m.sigma_s[1], m.sigma_s[2]) / kMetresPerMm;
    s.sigma_a = glm::dvec3(m.sigma_a[0], m.sigma_a[1], m.sigma_a[2]) / kMetresPerMm;
    s.eta = kJensenEta;
    s.preset = m.name;
    return s;
  }
  return std::nullopt;
}

std::span<const char* const> subsurfacePresetNames() {
  return kNames;
}

glm::dvec3 lambertianAlbedo(const Subsurface& medium) {
  const double t = 1.0 - externalDiffuseFresnelReflectance(medium.eta);
  return t * t * Dipole(medium.sigma_s_prime, medium.sigma_a, medium.eta).totalReflectance();
}

Status checkSubsurface(const Subsurface& medium) {
  for (int c = 0; c < 3; ++c) {
    const double s = medium.sigma_s_prime[c], a = medium.sigma_a[c];
    if (!std::isfinite(s) || s < 0.0) {
      return inputError("", "", fmt::format("sigma_s' {} is not a non-negative number", s));
    }
    if (!std::isfinite(a) || a < 0.0) {
      return inputError("", "", fmt::format("sigma_a {} is not a non-negative number", a));
    }
    if (!(s + a > 0.0)) {
      return inputError("", "",
                        "a channel with sigma_s' + sigma_a = 0 is not a medium (light would "
                        "travel forever)");
    }
  }
  if (!(medium.eta >= 1.0 && medium.eta <= 4.0)) {
    return inputError("", "",
                      fmt::format("eta {} is outside [1, 4] (the index of refraction relative to "
                                  "the outside)",
                                  medium.eta));
  }
  if (!(medium.g > -1.0 && medium.g < 1.0)) {
    return inputError("", "", fmt::format("g {} is outside (-1, 1)", medium.g));
  }
  return {};
}

Expected<Subsurface> subsurfaceFromCoefficients(const glm::dvec3& sigma_s_prime_per_mm,
                                                const glm::dvec3& sigma_a_per_mm, double eta) {
  Subsurface s;
  s.sigma_s_prime = sigma_s_prime_per_mm / kMetresPerMm;
  s.sigma_a = sigma_a_per_mm / kMetresPerMm;
  s.eta = eta;
  PENUMBRA_TRY(checkSubsurface(s));
  return s;
}

Expected<Subsurface> subsurfaceFromAlbedo(const glm::dvec3& albedo, const glm::dvec3& distance,
                                          double eta) {
  if (!(eta >= 1.0 && eta <= 4.0)) {
    return inputError("", "", fmt::format("eta {} is outside [1, 4]", eta));
  }
  Subsurface s;
  s.eta = eta;
  for (int c = 0; c < 3; ++c) {
    if (!(albedo[c] >= 0.0 && albedo[c] < 1.0)) {
      return inputError("", "", fmt::format("albedo {} is outside [0, 1)", albedo[c]));
    }
    if (!(distance[c] > 0.0 && std::isfinite(distance[c]))) {
      return inputError("", "", fmt::format("distance {} is not a positive number", distance[c]));
    }
    // R_d(alpha') rises monotonically from 0 to 1 on [0, 1].
    double lo = 0.0, hi = 1.0;
    for (int i = 0; i < 60; ++i) {
      const double mid = 0.5 * (lo + hi);
      (totalDiffuseReflectance(mid, eta) < albedo[c] ? lo : hi) = mid;
    }
    const double alpha = 0.5 * (lo + hi);
    // sigma_tr = sqrt(3 sigma_a sigma_t') = sigma_t' sqrt(3 (1 - alpha')).
    const double sigma_t = 1.0 / (distance[c] * std::sqrt(3.0 * (1.0 - alpha)));
    s.sigma_s_prime[c] = alpha * sigma_t;
    s.sigma_a[c] = sigma_t - s.sigma_s_prime[c];
  }
  PENUMBRA_TRY(checkSubsurface(s));
  return s;
}

}  // namespace penumbra
