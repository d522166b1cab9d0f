// Daylight (scene/sky.h): the CIE general skies against published values of their formulas, the
// horizontal illuminance against closed forms, the sun's position against astronomical facts
// (the declination at the solstice, the equation of time in February and November, the sun due
// south at solar noon), and the glazing's transmittance against the Fresnel slab.
#include "penumbra/scene/sky.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace penumbra {
namespace {

Sky skyOf(int type, double sun_elevation, double sun_azimuth) {
  Sky s;
  s.type = type;
  s.zenith_luminance = 1.0;
  s.sun_elevation_deg = sun_elevation;
  s.sun_azimuth_deg = sun_azimuth;
  s.prepare();
  return s;
}

TEST(Sky, RelativeLuminanceMatchesTheStandardsFormula) {
  // The sun 30 degrees from the zenith at azimuth 0; the element 45 degrees from the zenith
  // opposite it (values of ISO 15469's formula as colour-science's tests state them).
  const Sky overcast = skyOf(1, 60.0, 0.0), clear = skyOf(12, 60.0, 0.0);
  const glm::dvec3 d = overcast.direction(45.0, 180.0);
  EXPECT_NEAR(overcast.relativeLuminance(d), 0.8325846, 1e-6);
  EXPECT_NEAR(clear.relativeLuminance(d), 0.4544524, 1e-6);
  // The zenith is L_z; below the horizon the sky is dark (the ground takes over).
  EXPECT_NEAR(clear.relativeLuminance(glm::dvec3(0, 1, 0)), 1.0, 1e-12);
  EXPECT_EQ(clear.relativeLuminance(glm::dvec3(0, -1, 0)), 0.0);
  // The traditional overcast sky: the zenith three times the horizon.
  const Sky traditional = skyOf(16, 45.0, 0.0);
  EXPECT_NEAR(traditional.relativeLuminance(traditional.direction(0.0, 90.0)), 1.0 / 3.0, 1e-12);
}

TEST(Sky, HorizontalIlluminanceOverZenithLuminance) {
  EXPECT_NEAR(skyOf(5, 45, 0).horizontalPerZenith(), std::numbers::pi, 1e-12);
  EXPECT_NEAR(skyOf(16, 45, 0).horizontalPerZenith(), 7.0 * std::numbers::pi / 9.0, 1e-12);
  // Type 1 integrated: 2.4495 (Kittler and Darula's L_z / D_v = 54.63 / 133.8 gives 2.4492).
  EXPECT_NEAR(skyOf(1, 45, 0).horizontalPerZenith(), 2.4495, 2e-3);
}

TEST(Sky, GroundIsTheUnshadedLambertianOfItsReflectance) {
  Sky s = skyOf(5, 45, 0);
  s.zenith_luminance = 1000.0;
  s.ground_reflectance = 0.3;
  s.prepare();
  // E_h = pi L_z on the uniform sky: the ground's luminance is rho L_z.
  EXPECT_NEAR(s.luminance(glm::dvec3(0, -1, 0)), 0.3 * 1000.0, 1e-9);
  s.sun_illuminance = 50000.0;  // the beam adds 50,000 sin(45 degrees) lx on the ground
  s.prepare();
  EXPECT_NEAR(s.groundLuminance(),
              0.3 * (1000.0 * std::numbers::pi + 50000.0 * std::sqrt(0.5)) / std::numbers::pi,
              1e-6);
}

TEST(Sky, SunPositionAgreesWithAstronomicalFacts) {
  // The June solstice: declination 23.44 degrees.
  const SunPosition june = sunPosition(2024, 6, 20, 20.85, 0.0, 0.0, 0.0);
  EXPECT_NEAR(june.declination_deg, 23.44, 0.01);
  // The equation of time: about -14.2 min on 11 February, +16.4 min on 3 November.
  EXPECT_NEAR(sunPosition(2024, 2, 11, 12.0, 0.0, 0.0, 0.0).equation_of_time_min, -14.2, 0.2);
  EXPECT_NEAR(sunPosition(2024, 11, 3, 12.0, 0.0, 0.0, 0.0).equation_of_time_min, 16.4, 0.2);
  // At solar noon (12:00 less the equation of time at longitude 0) the sun stands due south of
  // a place north of the tropics, 90 - (latitude - declination) high.
  const SunPosition probe = sunPosition(2024, 6, 21, 12.0, 0.0, 40.0, 0.0);
  const double noon = 12.0 - probe.equation_of_time_min / 60.0;
  const SunPosition at_noon = sunPosition(2024, 6, 21, noon, 0.0, 40.0, 0.0);
  EXPECT_NEAR(at_noon.azimuth_deg, 180.0, 0.05);
  EXPECT_NEAR(at_noon.elevation_deg, 90.0 - (40.0 - at_noon.declination_deg), 0.01);
  // Local time and longitude: Vienna (16.37 E, UTC+1) on the March equinox at 12:00 local; the
  // sun is east of south before solar noon there (12:00 CET is 11:05 local solar time).
  const SunPosition vienna = sunPosition(2024, 3, 20, 12.0, 1.0, 48.21, 16.37);
  EXPECT_LT(vienna.azimuth_deg, 180.0);
  EXPECT_GT(vienna.azimuth_deg, 160.0);
  EXPECT_NEAR(vienna.elevation_deg, 90.0 - 48.21, 1.5);
}

TEST(Sky, GlazingFollowsTheFresnelSlab) {
  Opening glass;
  glass.glazed = true;
  glass.transmittance = 0.878;
  EXPECT_NEAR(glass.transmittanceAt(1.0), 0.878, 1e-12);
  // A non-absorbing n = 1.52 slab transmits 0.9183 at normal incidence and 0.456 at 80 degrees.
  EXPECT_NEAR(slabTransmittance(1.0, 1.52), 0.9183, 1e-4);
  EXPECT_NEAR(slabTransmittance(std::cos(80.0 * std::numbers::pi / 180.0), 1.52), 0.456, 2e-3);
  EXPECT_EQ(glass.transmittanceAt(0.0), 0.0);
  Opening open;
  EXPECT_EQ(open.transmittanceAt(0.3), 1.0);
}

}  // namespace
}  // namespace penumbra
