// Luminaires: a point source whose intensity follows a measured light distribution (a
// manufacturer's EULUMDAT or IES file), through the light distribution texture (LDT) of Wallner,
// "GPU radiosity for triangular meshes with support of normal mapping and arbitrary light
// distributions", sec. 3.2.
//
// The LDT holds the distribution normalised by its maximum I_max: each row one C plane, each
// column one gamma angle, sampled bilinearly and wrapping in C (the paper's GL_REPEAT). The paper
// stores one half space (n'_g columns, gamma in [0, 90]); Penumbra stores the whole sphere,
// gamma in [0, 180], so that luminaires with an upward component (pendants, uplights) keep it:
// for gamma <= 90 degrees the coordinate below is the paper's eq. 13 scaled by one half.
//
// The luminaire's frame (the photometric C-gamma system of EN 13032 and IES LM-63 type C):
// gamma = 0 along `nadir` (the way the luminaire points), C = 0 along `c0` (perpendicular to
// it), C = 90 along c0 x nadir, so that C grows anticlockwise seen from above a downlight. A
// direction d has cos(gamma) = d . nadir and C = atan2(d . c90, d . c0) in [0, 360).
//
// Units: the file gives luminous intensity (cd); Penumbra's lights are radiometric. Wallner's
// eq. 12 takes I_e = I_v / 683 (all the light at 555 nm), so `scale` is I_max / 683 W sr^-1 per
// LDT unit per channel, times the user's dimming and colour. Illuminance in lux is 683 times the
// irradiance's luminance (render/photometric.h), so a luminaire's lux come out as its file says.
#pragma once

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace penumbra {

// Luminous efficacy taken for the conversion between photometric and radiometric units
// (Wallner eq. 11-12: monochromatic light at 555 nm).
inline constexpr double kLumensPerWatt = 683.0;

// The luminous opening a photometric file states (io/photometry.h), metres: a box `length`
// along the luminaire's C0 axis, `width` along C90 and `height` deep, or a disc (cylinder) of
// diameter `length` when `round`; all zero when the file states none. For glare
// (render/glare_index.h), not for the light.
struct LuminousOpening {
  double length = 0.0, width = 0.0, height = 0.0;
  bool round = false;
};

// The light distribution texture (Wallner sec. 3.2): `gamma_count` samples from gamma = 0 to 180
// degrees inclusive in each of `c_count` planes C = 0, 360 / c_count, ... (C = 360 is C = 0).
struct LuminaireDistribution {
  std::string source;        // the file it came from, for messages and `info`
  int gamma_count = 0;       // n'_g
  int c_count = 0;           // m_c
  std::vector<float> table;  // c_count rows of gamma_count values, normalised to max 1
  double max_candela = 0.0;  // I_max, cd
  double flux_lumens = 0.0;  // the flux of the distribution (integrated over the sphere), lm
  // The distribution's cells as a discrete distribution for emission sampling: cumulative
  // weights (solid angle times the cell's largest corner) over the (c_count x gamma_count - 1)
  // cells, row-major by plane; the last entry is the total.
  std::vector<double> cell_cdf;
  LuminousOpening opening;  // what the file states

  // The LDT of a distribution given in candela on the regular grid above (c_count rows of
  // gamma_count values). Refuses (returns false with `why`) grids smaller than 2 x 1, negative
  // or non-finite values, and an all-zero distribution.
  static bool fromCandela(int c_count, int gamma_count, const std::vector<double>& candela,
                          std::string source, LuminaireDistribution& out, std::string& why);
};

// A luminaire placed in a scene.
struct LuminaireLight {
  glm::vec3 position{0.0f};
  glm::vec3 nadir{0.0f, -1.0f, 0.0f};  // unit: gamma = 0
  glm::vec3 c0{1.0f, 0.0f, 0.0f};      // unit, perpendicular to nadir: C = 0
  // W sr^-1 per LDT unit, per channel: I_max / 683 x dimming x colour (x lamps / stated lamps).
  glm::vec3 scale{1.0f};
  std::shared_ptr<const LuminaireDistribution> distribution;

  glm::vec3 c90() const { return glm::cross(c0, nadir); }
};

// Texture coordinates of direction `d` (unit, world space, from the luminaire outwards) in the
// LDT: x_t = gamma / 180 degrees (eq. 13 over the whole sphere), y_t = C / 360 degrees in [0, 1)
// (eq. 14: the azimuth and its mirror image 1 - azimuth on the other side of the C0-C180 plane).
// Single precision, as shaders/common/luminaire.glsl computes it.
inline void luminaireTexCoords(const LuminaireLight& l, const glm::vec3& d, float& xt, float& yt) {
  constexpr float kPiF = 3.14159265358979f;
  const float cos_g = std::clamp(glm::dot(d, l.nadir), -1.0f, 1.0f);
  xt = std::acos(cos_g) / kPiF;
  const float x = glm::dot(d, l.c0), y = glm::dot(d, l.c90());
  float phi = std::atan2(y, x) / (2.0f * kPiF);  // (-1/2, 1/2]
  if (phi < 0.0f) phi += 1.0f;
  yt = phi >= 1.0f ? 0.0f : phi;
}

// The LDT sampled bilinearly at (xt, yt): clamped in gamma, wrapping in C (GL_REPEAT).
inline float sampleLuminaireTable(const float* table, int gamma_count, int c_count, float xt,
                                  float yt) {
  const float g = std::clamp(xt, 0.0f, 1.0f) * float(gamma_count - 1);
  const int g0 = std::min(int(g), gamma_count - 2);
  const float fg = g - float(g0);
  const float c = yt * float(c_count);
  const int c_floor = int(std::floor(c));
  const float fc = c - float(c_floor);
  const int c0 = ((c_floor % c_count) + c_count) % c_count;
  const int c1 = (c0 + 1) % c_count;
  const float* r0 = table + size_t(c0) * size_t(gamma_count);
  const float* r1 = table + size_t(c1) * size_t(gamma_count);
  const float a = r0[g0] + fg * (r0[g0 + 1] - r0[g0]);
  const float b = r1[g0] + fg * (r1[g0 + 1] - r1[g0]);
  return a + fc * (b - a);
}

// Eq. 15's I(T, d_0): the luminaire's radiant intensity (W sr^-1) towards unit direction `d`.
inline glm::vec3 luminaireIntensity(const LuminaireLight& l, const glm::vec3& d) {
  const LuminaireDistribution& t = *l.distribution;
  float xt = 0.0f, yt = 0.0f;
  luminaireTexCoords(l, d, xt, yt);
  return l.scale * sampleLuminaireTable(t.table.data(), t.gamma_count, t.c_count, xt, yt);
}

// The radiant power of the luminaire (W per channel): scale x the LDT's integral over the sphere.
glm::dvec3 luminairePower(const LuminaireLight& l);

// A direction distributed as the luminaire's emission (proportional to its intensity): a cell
// chosen by `cell_cdf`, a point in it uniform in solid angle, kept with probability value /
// the cell's largest corner. Uses a few uniform numbers from `uniform()` per attempt.
template <typename Uniform>
glm::vec3 sampleLuminaireDirection(const LuminaireLight& l, Uniform&& uniform) {
  constexpr double kPiD = 3.14159265358979323846;
  const LuminaireDistribution& t = *l.distribution;
  const int cells_per_row = t.gamma_count - 1;
  for (int attempt = 0; attempt < 256; ++attempt) {
    const double u = double(uniform()) * t.cell_cdf.back();
    const size_t cell =
        size_t(std::upper_bound(t.cell_cdf.begin(), t.cell_cdf.end() - 1, u) - t.cell_cdf.begin());
    const int ci = int(cell) / cells_per_row, gi = int(cell) % cells_per_row;
    const double g0 = kPiD * gi / cells_per_row, g1 = kPiD * (gi + 1) / cells_per_row;
    const double cos_g = std::cos(g0) + double(uniform()) * (std::cos(g1) - std::cos(g0));
    const double c = 2.0 * kPiD * (ci + double(uniform())) / t.c_count;
    const double sin_g = std::sqrt(std::max(0.0, 1.0 - cos_g * cos_g));
    const glm::vec3 d =
        glm::normalize(float(sin_g * std::cos(c)) * l.c0 + float(sin_g * std::sin(c)) * l.c90() +
                       float(cos_g) * l.nadir);
    const float* r0 = t.table.data() + size_t(ci) * size_t(t.gamma_count);
    const float* r1 = t.table.data() + size_t((ci + 1) % t.c_count) * size_t(t.gamma_count);
    const float peak = std::max(std::max(r0[gi], r0[gi + 1]), std::max(r1[gi], r1[gi + 1]));
    float xt = 0.0f, yt = 0.0f;
    luminaireTexCoords(l, d, xt, yt);
    const float value = sampleLuminaireTable(t.table.data(), t.gamma_count, t.c_count, xt, yt);
    if (double(uniform()) * peak <= value) return d;
  }
  return l.nadir;
}

}  // namespace penumbra
