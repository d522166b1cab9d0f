#include "penumbra/render/ugr_table.h"

#include "penumbra/render/glare_index.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace penumbra {

namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

// CIE 190:2010 Table 4, k = 2.67: the shares F_GL of the cumulative zonal fluxes to 41.3, 60,
// 75.5 and 90 degrees that reach the floor directly.
constexpr std::array<double, 4> kFloorShares = {0.280, 0.165, 0.499, 0.006};

// CIE 190:2010 Table 5, k = 2.67, in kUgrReflectances' order: F_T,FW (floor to walls), F_T,WW-1
// (walls to walls, the direct part taken out), F_T,CW (ceiling to walls).
constexpr std::array<std::array<double, 3>, 5> kTransfer = {{
    {0.115, 0.211, 0.307},
    {0.106, 0.117, 0.283},
    {0.100, 0.187, 0.211},
    {0.093, 0.104, 0.196},
    {0.081, 0.092, 0.114},
}};

}  // namespace

std::string UgrReflectances::label() const {
  return fmt::format("{:.0f}/{:.0f}/{:.0f}", ceiling * 100.0, walls * 100.0, floor * 100.0);
}

double ugrLuminaireFlux(const Photometry& photometry) {
  return photometry.integratedFlux();
}

// CIE 190 sec. 4.2: the zonal flux of each 10-degree zone from the mean intensity over the C
// planes at its midpoint, G = I(gamma_m) 2 pi sin(gamma_m) 10 deg, normalised to the luminaire's
// flux; eq. 9-12 for the split.
UgrZonalFlux ugrZonalFlux(const Photometry& photometry) {
  std::array<double, 18> g{};
  double sum = 0.0;
  constexpr int kPlanes = 360;
  for (int z = 0; z < 18; ++z) {
    const double gamma = 5.0 + 10.0 * z;
    double mean = 0.0;
    for (int c = 0; c < kPlanes; ++c) mean += photometry.intensity(c + 0.5, gamma);
    mean /= kPlanes;
    g[size_t(z)] = mean * 2.0 * std::numbers::pi * std::sin(gamma * kDegree) * 10.0 * kDegree;
    sum += g[size_t(z)];
  }
  UgrZonalFlux out;
  if (!(sum > 0.0)) return out;
  const double scale = ugrLuminaireFlux(photometry) / sum;
  for (double& v : g) v *= scale;
  auto to = [&](int zones) {
    double s = 0.0;
    for (int z = 0; z < zones; ++z) s += g[size_t(z)];
    return s;
  };
  const std::array<double, 4> cumulative = {to(4) + 0.130 * g[4], to(6), to(7) + 0.547 * g[7],
                                            to(9)};
  out.down = to(9);
  out.up = to(18) - out.down;
  for (size_t k = 0; k < 4; ++k) out.floor += kFloorShares[k] * cumulative[k];
  return out;
}

std::vector<UgrPosition> ugrLuminairePositions(const UgrRoom& room) {
  const double s = room.spacing_to_height * kUgrMountingHeight;
  const int across = int(std::lround(room.x_h * kUgrMountingHeight / s));
  const int along = int(std::lround(room.y_h * kUgrMountingHeight / s));
  std::vector<UgrPosition> out;
  for (int j = 0; j < along; ++j) {
    for (int i = 0; i < across; ++i) {
      out.push_back({(j + 0.5) * s, (i + 0.5 - 0.5 * across) * s});
    }
  }
  return out;
}

double ugrTabularSum(const Photometry& photometry, const UgrRoom& room, bool endwise) {
  const LuminousOpening opening{photometry.length, photometry.width, photometry.height,
                                photometry.circular};
  const double h = kUgrMountingHeight;
  double sum = 0.0;
  for (const UgrPosition& at : ugrLuminairePositions(room)) {
    const double horizontal = std::hypot(at.r, at.t);
    const double gamma = std::atan2(horizontal, h);
    if (gamma > 85.0 * kDegree) continue;
    const double across = std::atan2(at.t, at.r);  // CIE 117 eq. 4.5
    double c = endwise ? 0.5 * std::numbers::pi - across : across;
    if (c < 0.0) c += 2.0 * std::numbers::pi;
    const double intensity = photometry.intensity(c / kDegree, gamma / kDegree);
    const double x = std::sin(gamma) * std::cos(c), y = std::sin(gamma) * std::sin(c);
    const double area = projectedLuminousArea(opening, x, y, std::cos(gamma));
    sum += glareTermOfIntensity(at.r, at.t, h, intensity, area).term;
  }
  return sum;
}

double ugrWallIndirectIlluminance(const UgrZonalFlux& f, const UgrRoom& room,
                                  size_t reflectance_set) {
  const std::array<double, 3>& t = kTransfer[reflectance_set];
  const double n = double(ugrLuminairePositions(room).size());
  const double walls = 2.0 * kUgrMountingHeight * kUgrMountingHeight * (room.x_h + room.y_h);
  return n / walls * (f.floor * t[0] + (f.down - f.floor) * t[1] + f.up * t[2]);
}

Expected<std::vector<UgrTableRow>> ugrTable(const Photometry& photometry,
                                            double spacing_to_height) {
  if (!(spacing_to_height >= 0.25 && spacing_to_height <= 1.0)) {
    return inputError(
        photometry.file, "",
        fmt::format("UGR table: spacing {} H is outside 0.25 H to 1 H", spacing_to_height));
  }
  const UgrZonalFlux flux = ugrZonalFlux(photometry);
  if (!(flux.down > 0.0)) {
    return inputError(photometry.file, "",
                      "UGR table: the luminaire sends no light below the horizontal");
  }
  std::vector<UgrTableRow> rows;
  for (const auto& [x, y] : {std::pair{4, 8}, std::pair{8, 4}}) {
    const UgrRoom room{x, y, spacing_to_height};
    const double cross = ugrTabularSum(photometry, room, false);
    const double end = ugrTabularSum(photometry, room, true);
    for (size_t k = 0; k < kUgrReflectances.size(); ++k) {
      UgrTableRow row{room, kUgrReflectances[k]};
      row.background_luminance = ugrWallIndirectIlluminance(flux, room, k) / std::numbers::pi;
      row.crosswise = unifiedGlareRating(row.background_luminance, cross);
      row.endwise = unifiedGlareRating(row.background_luminance, end);
      rows.push_back(row);
    }
  }
  return rows;
}

}  // namespace penumbra
