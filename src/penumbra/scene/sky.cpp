#include "penumbra/scene/sky.h"

#include "penumbra/scene/luminaire.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace penumbra {

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
const glm::dvec3 kUp(0.0, 1.0, 0.0);

double wrapDegrees(double a) {
  a = std::fmod(a, 360.0);
  return a < 0.0 ? a + 360.0 : a;
}

// Gradation and indicatrix (ISO 15469 eqs. 1-2); angles in radians.
double gradation(const std::array<double, 5>& p, double cos_z) {
  if (cos_z <= 0.0) return 1.0;  // the horizon: exp(b / 0+) = 0 for b < 0
  return 1.0 + p[0] * std::exp(p[1] / cos_z);
}

double indicatrix(const std::array<double, 5>& p, double chi) {
  const double c = std::cos(chi);
  return 1.0 + p[2] * (std::exp(p[3] * chi) - std::exp(p[3] * 0.5 * std::numbers::pi)) +
         p[4] * c * c;
}

}  // namespace

SunPosition sunPosition(int year, int month, int day, double hours, double utc_offset,
                        double latitude_deg, double longitude_deg) {
  // Julian day of the date at 0h UT (Meeus ch. 7), then the time in UT.
  int y = year, m = month;
  if (m <= 2) {
    y -= 1;
    m += 12;
  }
  const int a = y / 100, b = 2 - a + a / 4;
  const double ut_hours = hours - utc_offset;
  const double jd = std::floor(365.25 * (y + 4716)) + std::floor(30.6001 * (m + 1)) + day + b -
                    1524.5 + ut_hours / 24.0;
  const double t = (jd - 2451545.0) / 36525.0;  // Julian centuries from J2000.0
  // The sun's geometric mean longitude and anomaly, the orbit's eccentricity (Meeus ch. 25).
  const double l0 = wrapDegrees(280.46646 + t * (36000.76983 + 0.0003032 * t));
  const double m_anom = 357.52911 + t * (35999.05029 - 0.0001537 * t);
  const double e = 0.016708634 - t * (0.000042037 + 0.0000001267 * t);
  const double mr = m_anom * kDeg;
  const double centre = std::sin(mr) * (1.914602 - t * (0.004817 + 0.000014 * t)) +
                        std::sin(2 * mr) * (0.019993 - 0.000101 * t) + std::sin(3 * mr) * 0.000289;
  const double omega = 125.04 - 1934.136 * t;
  const double lambda = (l0 + centre - 0.00569 - 0.00478 * std::sin(omega * kDeg)) * kDeg;
  const double eps0 =
      23.0 + (26.0 + (21.448 - t * (46.815 + t * (0.00059 - t * 0.001813))) / 60.0) / 60.0;
  const double eps = (eps0 + 0.00256 * std::cos(omega * kDeg)) * kDeg;
  const double decl = std::asin(std::sin(eps) * std::sin(lambda));
  // The equation of time, minutes.
  const double yv = std::pow(std::tan(eps / 2.0), 2.0);
  const double l0r = l0 * kDeg;
  const double eot = 4.0 / kDeg *
                     (yv * std::sin(2 * l0r) - 2 * e * std::sin(mr) +
                      4 * e * yv * std::sin(mr) * std::cos(2 * l0r) -
                      0.5 * yv * yv * std::sin(4 * l0r) - 1.25 * e * e * std::sin(2 * mr));
  // True solar time and hour angle.
  double tst = std::fmod(ut_hours * 60.0 + eot + 4.0 * longitude_deg, 1440.0);
  if (tst < 0.0) tst += 1440.0;
  double ha = tst / 4.0 - 180.0;
  if (ha < -180.0) ha += 360.0;
  const double lat = latitude_deg * kDeg, har = ha * kDeg;
  const double cos_zen = std::clamp(
      std::sin(lat) * std::sin(decl) + std::cos(lat) * std::cos(decl) * std::cos(har), -1.0, 1.0);
  SunPosition s;
  s.elevation_deg = 90.0 - std::acos(cos_zen) / kDeg;
  // Azimuth clockwise from north.
  s.azimuth_deg = wrapDegrees(
      std::atan2(-std::cos(decl) * std::sin(har),
                 std::sin(decl) * std::cos(lat) - std::cos(decl) * std::sin(lat) * std::cos(har)) /
      kDeg);
  s.equation_of_time_min = eot;
  s.declination_deg = decl / kDeg;
  return s;
}

glm::dvec3 Sky::direction(double elevation_deg, double azimuth_deg) const {
  const glm::dvec3 east = glm::cross(north, kUp);
  const double el = elevation_deg * kDeg, az = azimuth_deg * kDeg;
  return std::cos(el) * (std::cos(az) * north + std::sin(az) * east) + std::sin(el) * kUp;
}

void Sky::prepare() {
  north = glm::normalize(north - glm::dot(north, kUp) * kUp);
  sun_ = direction(sun_elevation_deg, sun_azimuth_deg);
  if (type >= 1 && type <= 15) {
    const std::array<double, 5>& p = kCieSkyTypes[size_t(type - 1)];
    const double zs = std::acos(std::clamp(glm::dot(sun_, kUp), -1.0, 1.0));
    norm_ = 1.0 / (indicatrix(p, zs) * gradation(p, 1.0));
  }
  horizontal_per_zenith_ = type == 5    ? std::numbers::pi
                           : type == 16 ? 7.0 * std::numbers::pi / 9.0
                                        : integrateHorizontal();
}

double Sky::relativeLuminance(const glm::dvec3& dir) const {
  const double cos_z = glm::dot(dir, kUp);
  if (cos_z < 0.0) return 0.0;
  if (type == 16) return (1.0 + 2.0 * cos_z) / 3.0;
  const std::array<double, 5>& p = kCieSkyTypes[size_t(std::clamp(type, 1, 15) - 1)];
  const double chi = std::acos(std::clamp(glm::dot(dir, sun_), -1.0, 1.0));
  return indicatrix(p, chi) * gradation(p, cos_z) * norm_;
}

double Sky::integrateHorizontal() const {
  // Midpoint rule in (cos^2 Z, azimuth): E_h / L_z = int L / L_z cos Z sin Z dZ dalpha
  // = 1/2 int L / L_z d(cos^2 Z) dalpha. 400 x 720 cells: the circumsolar peak of type 15
  // resolved to 0.01%.
  constexpr int kRings = 400, kSectors = 720;
  double sum = 0.0;
  const glm::dvec3 east = glm::cross(north, kUp);
  for (int i = 0; i < kRings; ++i) {
    const double u = (i + 0.5) / kRings;  // cos^2 Z
    const double cz = std::sqrt(u), sz = std::sqrt(1.0 - u);
    for (int j = 0; j < kSectors; ++j) {
      const double az = (j + 0.5) / kSectors * 2.0 * std::numbers::pi;
      const glm::dvec3 d = sz * (std::cos(az) * north + std::sin(az) * east) + cz * kUp;
      sum += relativeLuminance(d);
    }
  }
  return 0.5 * sum / (kRings * kSectors) * 2.0 * std::numbers::pi;
}

double Sky::groundLuminance() const {
  const double beam = sun_illuminance * std::max(0.0, std::sin(sun_elevation_deg * kDeg));
  return ground_reflectance * (horizontalIlluminance() + beam) / std::numbers::pi;
}

double Sky::luminance(const glm::dvec3& dir) const {
  if (glm::dot(dir, kUp) < 0.0) return groundLuminance();
  return zenith_luminance * relativeLuminance(dir);
}

glm::vec3 Sky::radiance(const glm::dvec3& dir) const {
  return glm::vec3(float(luminance(dir) / kLumensPerWatt));
}

double slabTransmittance(double cos_theta, double ior) {
  const double ci = std::clamp(cos_theta, 0.0, 1.0);
  if (ci <= 0.0) return 0.0;
  const double si = std::sqrt(std::max(0.0, 1.0 - ci * ci));
  const double st = si / ior, ct = std::sqrt(std::max(0.0, 1.0 - st * st));
  const double rs = std::pow((ci - ior * ct) / (ci + ior * ct), 2.0);
  const double rp = std::pow((ior * ci - ct) / (ior * ci + ct), 2.0);
  return 0.5 * ((1.0 - rs) / (1.0 + rs) + (1.0 - rp) / (1.0 + rp));
}

double crossOpening(const Opening& opening, const glm::dvec3& o, const glm::dvec3& d) {
  const std::vector<glm::dvec3>& c = opening.corners;
  glm::dvec3 n(0.0);
  for (size_t k = 1; k + 1 < c.size(); ++k) n += glm::cross(c[k] - c[0], c[k + 1] - c[0]);
  const double dn = glm::dot(d, n);
  if (std::fabs(dn) < 1e-300) return -1.0;
  const double t = glm::dot(c[0] - o, n) / dn;
  if (!(t > 0.0)) return -1.0;
  const glm::dvec3 p = o + t * d;
  // Inside the convex polygon: on the inner side of every edge.
  for (size_t k = 0; k < c.size(); ++k) {
    const glm::dvec3& a = c[k];
    const glm::dvec3& b = c[(k + 1) % c.size()];
    if (glm::dot(glm::cross(b - a, p - a), n) < 0.0) return -1.0;
  }
  return t;
}

double transmittanceThrough(const std::vector<Opening>& openings, const glm::dvec3& o,
                            const glm::dvec3& d, double max_distance) {
  double tau = 1.0;
  const glm::dvec3 u = glm::normalize(d);
  for (const Opening& op : openings) {
    if (!op.glazed) continue;
    const double t = crossOpening(op, o, u);
    if (!(t > 0.0) || !(t < max_distance)) continue;
    glm::dvec3 n(0.0);
    for (size_t k = 1; k + 1 < op.corners.size(); ++k) {
      n += glm::cross(op.corners[k] - op.corners[0], op.corners[k + 1] - op.corners[0]);
    }
    tau *= op.transmittanceAt(glm::dot(glm::normalize(n), u));
  }
  return tau;
}

bool anyGlazing(const std::vector<Opening>& openings) {
  for (const Opening& op : openings) {
    if (op.glazed) return true;
  }
  return false;
}

double clearGlassTransmittance(double c) {
  c = std::clamp(c, 0.0, 1.0);
  const double p =
      -0.028378 +
      c * (3.156075 + c * (-3.058376 + c * (-1.428919 + c * (4.014235 - 1.775827 * c))));
  return std::max(p, 0.0);
}

double Opening::transmittanceAt(double cos_theta) const {
  if (!glazed) return 1.0;
  const double c = std::fabs(cos_theta);
  if (falloff == GlazingFalloff::kClearGlass) {
    return transmittance * clearGlassTransmittance(c) / clearGlassTransmittance(1.0);
  }
  return transmittance * slabTransmittance(c, ior) / slabTransmittance(1.0, ior);
}

}  // namespace penumbra
