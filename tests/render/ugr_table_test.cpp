// The tabular UGR method of CIE 190:2010 (render/ugr_table.h): the zonal-flux chain on a
// Lambertian distribution in closed form, the standard rooms' luminaire counts (CIE 190 Table 3),
// and the flux correction of CIE 190 eq. 2 (UGR grows by 8 log10 of the flux ratio).
#include "penumbra/render/ugr_table.h"
#include "penumbra/io/photometry.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace penumbra {
namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

// I = i0 cos(gamma) below the horizon, nothing above: a rotationally symmetric Lambertian
// downlight of flux pi i0.
Photometry lambertian(double i0) {
  Photometry p;
  p.file = "lambertian.ldt";
  p.type = PhotometricType::kC;
  p.planes = {0.0};
  for (int g = 0; g <= 180; ++g) {
    p.angles.push_back(g);
    p.candela.push_back(g <= 90 ? i0 * std::cos(g * kDegree) : 0.0);
  }
  p.length = p.width = 0.3;
  p.circular = true;
  return p;
}

// The share of a Lambertian downlight's flux within gamma of the nadir is sin^2(gamma), so the
// cumulative zonal fluxes of CIE 190 eq. 9 and the floor's share are known in closed form.
TEST(UgrTable, ZonalFluxOfALambertianDownlightIsTheClosedForm) {
  const Photometry p = lambertian(1000.0);
  const double flux = p.integratedFlux();
  EXPECT_NEAR(flux, std::numbers::pi * 1000.0, 0.5);
  auto within = [](double deg) { return std::pow(std::sin(deg * kDegree), 2); };
  const double cumulative[4] = {within(40) + 0.130 * (within(50) - within(40)), within(60),
                                within(70) + 0.547 * (within(80) - within(70)), 1.0};
  const double shares[4] = {0.280, 0.165, 0.499, 0.006};
  double floor = 0.0;
  for (int k = 0; k < 4; ++k) floor += shares[k] * cumulative[k] * flux;
  const UgrZonalFlux z = ugrZonalFlux(p);
  EXPECT_NEAR(z.down, flux, 1e-9 * flux);
  EXPECT_NEAR(z.up, 0.0, 1e-9 * flux);
  EXPECT_NEAR(z.floor, floor, 1e-3 * floor);
  // E_WID for 70/50/20 in 4H x 8H at S = 0.25 H: 512 luminaires over 96 m^2 of wall.
  const UgrRoom room{4, 8, 0.25};
  const double e = 512.0 / 96.0 * (z.floor * 0.115 + (z.down - z.floor) * 0.211);
  EXPECT_NEAR(ugrWallIndirectIlluminance(z, room, 0), e, 1e-9 * e);
}

TEST(UgrTable, StandardRoomsHoldTheLuminairesOfCie190Table3) {
  EXPECT_EQ(ugrLuminairePositions({4, 8, 1.0}).size(), 32u);
  EXPECT_EQ(ugrLuminairePositions({8, 4, 1.0}).size(), 32u);
  const std::vector<UgrPosition> fine = ugrLuminairePositions({4, 8, 0.25});
  ASSERT_EQ(fine.size(), 512u);
  double sum_t = 0.0, nearest = 1e9, farthest = 0.0;
  for (const UgrPosition& at : fine) {
    sum_t += at.t;
    nearest = std::min(nearest, at.r);
    farthest = std::max(farthest, at.r);
    EXPECT_LE(std::abs(at.t), 4.0);
  }
  EXPECT_NEAR(sum_t, 0.0, 1e-9);  // symmetric about the line of sight
  EXPECT_DOUBLE_EQ(nearest, 0.25);
  EXPECT_DOUBLE_EQ(farthest, 15.75);
}

// CIE 190 eq. 2: a luminaire of k times the flux (same distribution) rates 8 log10 k higher.
TEST(UgrTable, FluxScalesTheRatingBy8Log10) {
  Expected<std::vector<UgrTableRow>> one = ugrTable(lambertian(1000.0));
  Expected<std::vector<UgrTableRow>> three = ugrTable(lambertian(3000.0));
  ASSERT_TRUE(one && three);
  ASSERT_EQ(one->size(), 10u);
  for (size_t i = 0; i < one->size(); ++i) {
    EXPECT_NEAR((*three)[i].crosswise - (*one)[i].crosswise, 8.0 * std::log10(3.0), 1e-9);
    // A rotationally symmetric luminaire rates the same both ways.
    EXPECT_NEAR((*one)[i].crosswise, (*one)[i].endwise, 1e-9);
  }
  // Darker walls, less background: a higher rating.
  EXPECT_GT((*one)[4].crosswise, (*one)[0].crosswise);
  Expected<std::vector<UgrTableRow>> bad = ugrTable(lambertian(1000.0), 2.0);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("spacing"), std::string::npos);
}

}  // namespace
}  // namespace penumbra
