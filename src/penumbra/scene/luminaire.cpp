#include "penumbra/scene/luminaire.h"

#include <fmt/format.h>

#include <cmath>
#include <numbers>

namespace penumbra {

namespace {

// The integral over the sphere of the LDT read bilinearly (sampleLuminaireTable), exactly: in C
// the mean of two planes times the plane spacing; in gamma, with I linear between g0 and g1,
//   int_g0^g1 I(g) sin(g) dg = I0 (cos g0 - cos g1) + (I1 - I0) / h (sin g1 - sin g0 - h cos g1).
double tableIntegral(const LuminaireDistribution& t) {
  const double pi = std::numbers::pi;
  const double dc = 2.0 * pi / t.c_count, h = pi / (t.gamma_count - 1);
  double sum = 0.0;
  for (int c = 0; c < t.c_count; ++c) {
    const float* r0 = t.table.data() + size_t(c) * size_t(t.gamma_count);
    const float* r1 = t.table.data() + size_t((c + 1) % t.c_count) * size_t(t.gamma_count);
    for (int g = 0; g + 1 < t.gamma_count; ++g) {
      const double g0 = h * g, g1 = h * (g + 1);
      const double i0 = 0.5 * (double(r0[g]) + double(r1[g]));
      const double i1 = 0.5 * (double(r0[g + 1]) + double(r1[g + 1]));
      sum += dc * (i0 * (std::cos(g0) - std::cos(g1)) +
                   (i1 - i0) / h * (std::sin(g1) - std::sin(g0) - h * std::cos(g1)));
    }
  }
  return sum;
}

}  // namespace

bool LuminaireDistribution::fromCandela(int c_count, int gamma_count,
                                        const std::vector<double>& candela, std::string source,
                                        LuminaireDistribution& out, std::string& why) {
  if (c_count < 1 || gamma_count < 2 || candela.size() != size_t(c_count) * size_t(gamma_count)) {
    why = fmt::format(
        "a light distribution needs at least 1 x 2 values (got {} planes x {} "
        "angles, {} values)",
        c_count, gamma_count, candela.size());
    return false;
  }
  double peak = 0.0;
  for (double v : candela) {
    if (!std::isfinite(v) || v < 0.0) {
      why = fmt::format("intensity {} cd is not a finite non-negative number", v);
      return false;
    }
    peak = std::max(peak, v);
  }
  if (!(peak > 0.0)) {
    why = "the light distribution is zero everywhere";
    return false;
  }
  LuminaireDistribution t;
  t.source = std::move(source);
  t.c_count = c_count;
  t.gamma_count = gamma_count;
  t.max_candela = peak;
  t.table.resize(candela.size());
  for (size_t i = 0; i < candela.size(); ++i) t.table[i] = float(candela[i] / peak);
  t.flux_lumens = peak * tableIntegral(t);
  // Cells for emission sampling: solid angle times the largest corner (sampleLuminaireDirection).
  const double pi = std::numbers::pi;
  const double dc = 2.0 * pi / c_count, h = pi / (gamma_count - 1);
  t.cell_cdf.reserve(size_t(c_count) * size_t(gamma_count - 1));
  double total = 0.0;
  for (int c = 0; c < c_count; ++c) {
    const float* r0 = t.table.data() + size_t(c) * size_t(gamma_count);
    const float* r1 = t.table.data() + size_t((c + 1) % c_count) * size_t(gamma_count);
    for (int g = 0; g + 1 < gamma_count; ++g) {
      const double peak_cell = std::max(std::max(r0[g], r0[g + 1]), std::max(r1[g], r1[g + 1]));
      total += peak_cell * dc * (std::cos(h * g) - std::cos(h * (g + 1)));
      t.cell_cdf.push_back(total);
    }
  }
  out = std::move(t);
  return true;
}

glm::dvec3 luminairePower(const LuminaireLight& l) {
  const LuminaireDistribution& t = *l.distribution;
  return glm::dvec3(l.scale) * (t.flux_lumens / t.max_candela);
}

}  // namespace penumbra
