#include "penumbra/io/luminaire_io.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace penumbra {

namespace {

// The smallest positive spacing of ascending `angles`, or `fallback` when there is none.
double smallestStep(const std::vector<double>& angles, double fallback) {
  double step = fallback;
  for (size_t i = 1; i < angles.size(); ++i) {
    const double d = angles[i] - angles[i - 1];
    if (d > 1e-9) step = std::min(step, d);
  }
  return step;
}

// Samples covering `span` degrees at about `step` spacing (a whole number of steps).
int countFor(double span, double step, double finest) {
  const double s = std::max(step, finest);
  return int(std::ceil(span / s - 1e-6));
}

}  // namespace

Expected<std::shared_ptr<const LuminaireDistribution>> luminaireDistribution(
    const Photometry& photometry, double tilt_degrees) {
  int c_count = 360, gamma_count = 181;  // 1-degree grid for types A and B
  if (photometry.type == PhotometricType::kC) {
    // One plane: rotationally symmetric, one row. Otherwise the file's finest spacing in C
    // (including the wrap from the last plane back to 360) and in gamma.
    if (photometry.planes.size() <= 1) {
      c_count = 1;
    } else {
      std::vector<double> planes = photometry.planes;
      planes.push_back(photometry.planes.front() + 360.0);
      c_count = std::clamp(countFor(360.0, smallestStep(planes, 360.0), 0.5), 4, 720);
    }
    gamma_count =
        std::clamp(countFor(180.0, smallestStep(photometry.angles, 180.0), 0.25) + 1, 3, 721);
  }
  std::vector<double> cd = photometry.resampleC(c_count, gamma_count);
  const double tilt = photometry.tiltFactor(tilt_degrees);
  for (double& v : cd) v *= tilt;
  auto t = std::make_shared<LuminaireDistribution>();
  std::string why;
  if (!LuminaireDistribution::fromCandela(c_count, gamma_count, cd, photometry.file, *t, why)) {
    return inputError(photometry.file, "", why);
  }
  t->opening = {photometry.length, photometry.width, photometry.height, photometry.circular};
  return std::shared_ptr<const LuminaireDistribution>(std::move(t));
}

Expected<std::shared_ptr<const LuminaireDistribution>> loadLuminaireDistribution(
    const std::string& path, double tilt_degrees) {
  Expected<Photometry> p = readPhotometry(path);
  if (!p) return p.error();
  return luminaireDistribution(*p, tilt_degrees);
}

}  // namespace penumbra
