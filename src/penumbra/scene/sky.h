// Daylight: the CIE standard general skies, the sun's position, and the ground.
//
// Sky luminance (ISO 15469:2004 / CIE S 011/E:2003): an element of the sky at zenith angle Z and
// angle chi from the sun has
//   L / L_z = f(chi) phi(Z) / (f(Z_s) phi(0)),
//   phi(Z) = 1 + a exp(b / cos Z)  (gradation; 1 at the horizon, where b < 0 drives exp to 0),
//   f(chi) = 1 + c (exp(d chi) - exp(d pi / 2)) + e cos^2 chi  (indicatrix),
//   cos chi = cos Z_s cos Z + sin Z_s sin Z cos(alpha - alpha_s),
// with (a, b, c, d, e) of the 15 types in kCieSkyTypes. Type 16 is the traditional CIE overcast
// sky, L / L_z = (1 + 2 cos Z) / 3, which CIE 171:2006 tabulates beside the 15.
//
// The absolute level is the zenith luminance L_z (cd/m^2), or the sky's horizontal illuminance
// E_h (lx), from which L_z follows by integrating L cos Z over the hemisphere.
//
// The sun's position from date, time and place (NOAA's solar calculator, after Meeus,
// "Astronomical Algorithms", 1998, ch. 25; about 0.01 degree for 1800-2100), or given as
// elevation and azimuth. Azimuth is clockwise from north. The scene's frame: y up, north along
// `north` (default -z), east = north x up (default +x).
//
// The ground outside: an unshaded Lambertian plane below the horizon of reflectance rho_g and
// luminance rho_g E / pi, E the horizontal illuminance of sky (and sun, when its beam is given),
// as CIE 171:2006 assumes for the externally reflected component.
#pragma once

#include <glm/vec3.hpp>

#include <array>
#include <limits>
#include <string>
#include <vector>

namespace penumbra {

// (a, b, c, d, e) of the CIE standard general skies 1-15 (ISO 15469:2004 Table 1).
inline constexpr std::array<std::array<double, 5>, 15> kCieSkyTypes = {{
    {4.0, -0.70, 0.0, -1.0, 0.00},    // 1 overcast, steep gradation, azimuthally uniform
    {4.0, -0.70, 2.0, -1.5, 0.15},    // 2 overcast, steep gradation, slight brightening to the sun
    {1.1, -0.80, 0.0, -1.0, 0.00},    // 3 overcast, moderate gradation, azimuthally uniform
    {1.1, -0.80, 2.0, -1.5, 0.15},    // 4 overcast, moderate gradation, slight brightening
    {0.0, -1.00, 0.0, -1.0, 0.00},    // 5 uniform luminance
    {0.0, -1.00, 2.0, -1.5, 0.15},    // 6 partly cloudy, no gradation, slight brightening
    {0.0, -1.00, 5.0, -2.5, 0.30},    // 7 partly cloudy, brighter circumsolar region
    {0.0, -1.00, 10.0, -3.0, 0.45},   // 8 partly cloudy, distinct solar corona
    {-1.0, -0.55, 2.0, -1.5, 0.15},   // 9 partly cloudy, sun obscured
    {-1.0, -0.55, 5.0, -2.5, 0.30},   // 10 partly cloudy, brighter circumsolar region
    {-1.0, -0.55, 10.0, -3.0, 0.45},  // 11 white-blue, distinct solar corona
    {-1.0, -0.32, 10.0, -3.0, 0.45},  // 12 CIE standard clear sky, low turbidity
    {-1.0, -0.32, 16.0, -3.0, 0.30},  // 13 CIE standard clear sky, polluted atmosphere
    {-1.0, -0.15, 16.0, -3.0, 0.30},  // 14 cloudless turbid, broad solar corona
    {-1.0, -0.15, 24.0, -2.8, 0.15},  // 15 white-blue turbid, broad solar corona
}};

// The sun's direction from a date and time at a place: elevation and azimuth in degrees (azimuth
// clockwise from north), without refraction. `utc_offset` hours east of Greenwich (Vienna in
// winter: +1), longitude east positive.
struct SunPosition {
  double elevation_deg = 0.0, azimuth_deg = 0.0;
  double equation_of_time_min = 0.0, declination_deg = 0.0;
};
SunPosition sunPosition(int year, int month, int day, double hours, double utc_offset,
                        double latitude_deg, double longitude_deg);

struct Sky {
  int type = 16;                  // 1-15: CIE general sky; 16: the traditional CIE overcast sky
  double zenith_luminance = 0.0;  // cd/m^2
  double sun_elevation_deg = 45.0, sun_azimuth_deg = 180.0;
  double ground_reflectance = 0.0;
  double sun_illuminance = 0.0;      // lx on a plane square to the beam; 0: no beam (sky only)
  glm::dvec3 north{0.0, 0.0, -1.0};  // horizontal, unit

  // After setting the type, the sun's position and north (and before any of the below): the
  // sun's direction, the normalisation and E_h / L_z, computed once. The levels (zenith
  // luminance, sun illuminance, ground reflectance) may change afterwards.
  void prepare();

  // The unit direction towards the sun, and the direction of a point at elevation / azimuth.
  glm::dvec3 sunDirection() const { return sun_; }
  glm::dvec3 direction(double elevation_deg, double azimuth_deg) const;

  // L / L_z of the sky towards unit `dir` (above the horizon; 0 below it).
  double relativeLuminance(const glm::dvec3& dir) const;
  // The sky's horizontal illuminance over its zenith luminance, E_h / L_z (sr), by integrating
  // L cos Z over the hemisphere (in prepare(); types 5 and 16 have it in closed form: pi and
  // 7 pi / 9).
  double horizontalPerZenith() const { return horizontal_per_zenith_; }
  // The sky's horizontal illuminance, lx (no sun beam).
  double horizontalIlluminance() const { return zenith_luminance * horizontalPerZenith(); }
  // The ground's luminance, cd/m^2: rho_g (E_h + the beam's horizontal illuminance) / pi.
  double groundLuminance() const;
  // What a ray leaving the scene along unit `dir` sees, cd/m^2: the sky above the horizon, the
  // ground below it.
  double luminance(const glm::dvec3& dir) const;
  // The same as radiance, W m^-2 sr^-1 (white: 1 / 683 per cd/m^2).
  glm::vec3 radiance(const glm::dvec3& dir) const;

 private:
  double integrateHorizontal() const;
  glm::dvec3 sun_{0.0, 1.0, 0.0};
  double norm_ = 1.0;  // 1 / (f(Z_s) phi(0))
  double horizontal_per_zenith_ = 0.0;
};

// How glazing's transmittance falls off with the angle of incidence theta (c = cos theta):
// - kFresnelSlab: T(theta) / T(0), T the transmittance of a non-absorbing slab of index `ior`
//   with its multiple reflections (Fresnel, averaged over both polarisations);
// - kClearGlass: P(c) / P(1), P the fit for clear glass that CIE 171:2006 takes for its glazed
//   cases (5.5, 5.10, 5.12; Tregenza and Sharples, "Daylighting algorithms", 1993, algorithm
//   2.34):  P(c) = -0.028378 + 3.156075 c - 3.058376 c^2 - 1.428919 c^3 + 4.014235 c^4
//   - 1.775827 c^5,  P(1) = 0.8788, held at 0 where it turns negative (beyond 88.9 degrees).
enum class GlazingFalloff { kFresnelSlab, kClearGlass };

// An opening in the building through which daylight enters (a window, a roof light): a convex
// polygon that is not geometry (nothing hits it) but where the sky is sampled for the light it
// sends in ("portal"). Glazing in it transmits tau(theta) = tau_n times the fall-off above, so
// that tau_n (which holds the glass's absorption) is the transmittance at normal incidence.
// Unglazed: tau = 1.
struct Opening {
  std::string name;
  std::vector<glm::dvec3> corners;  // a convex polygon, in order
  bool glazed = false;
  double transmittance = 1.0;  // tau_n
  double ior = 1.52;
  GlazingFalloff falloff = GlazingFalloff::kFresnelSlab;

  // The transmittance at incidence angle theta (cosine `cos_theta`).
  double transmittanceAt(double cos_theta) const;
};

// Where the ray o + t d (t > 0) crosses the opening's polygon, or a negative t.
double crossOpening(const Opening& opening, const glm::dvec3& o, const glm::dvec3& d);
// The product of the transmittances of the glazed openings the ray o + t d/|d| crosses for t in
// (0, max_distance): light from the sky, the sun or a lamp outside through the windows between.
double transmittanceThrough(const std::vector<Opening>& openings, const glm::dvec3& o,
                            const glm::dvec3& d,
                            double max_distance = std::numeric_limits<double>::infinity());
// Whether any opening is glazed (else transmittanceThrough is 1 everywhere).
bool anyGlazing(const std::vector<Opening>& openings);

// CIE 171:2006's clear-glass fit P(c) (GlazingFalloff::kClearGlass), not normalised.
double clearGlassTransmittance(double cos_theta);

// A slab's transmittance at incidence cos_theta: both interfaces and the light reflected between
// them, T = 1/2 sum over s and p of (1 - R) / (1 + R).
double slabTransmittance(double cos_theta, double ior);

}  // namespace penumbra
