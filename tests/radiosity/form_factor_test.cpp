// Form factors against closed forms (design doc sec. 6): Lambert's point-to-polygon formula
// integrated over a receiver, and the cluster matrix of a closed scene (rows sum to 1,
// reciprocity).
#include "penumbra/kernels/form_factor.h"
#include "penumbra/core/rng.h"
#include "penumbra/radiosity/form_factors.h"
#include "penumbra/scene/builtin.h"

#include <glm/geometric.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

namespace penumbra {
namespace {

// Area-averaged form factor from the unit square [0,1]^2 x {0} (normal +z) to `poly`, by the
// midpoint rule on a g x g grid (the integrand is smooth in the interior).
double squareToPolygon(const glm::dvec3* poly, int count, int g) {
  double sum = 0.0;
  for (int y = 0; y < g; ++y) {
    for (int x = 0; x < g; ++x) {
      const glm::dvec3 p((x + 0.5) / g, (y + 0.5) / g, 0.0);
      sum += pointToPolygonFormFactor(p, glm::dvec3(0, 0, 1), poly, count);
    }
  }
  return sum / double(g * g);
}

TEST(FormFactor, ParallelOpposedUnitSquaresOneApart) {
  const glm::dvec3 top[4] = {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  // Closed form (Howell's catalogue, C-11): 0.19982.
  EXPECT_NEAR(squareToPolygon(top, 4, 64), 0.19982, 0.19982 * 0.005);
}

TEST(FormFactor, PerpendicularUnitSquaresSharingAnEdge) {
  const glm::dvec3 wall[4] = {{0, 0, 0}, {0, 1, 0}, {0, 1, 1}, {0, 0, 1}};
  // Closed form (Howell's catalogue, C-14): 0.20004.
  EXPECT_NEAR(squareToPolygon(wall, 4, 256), 0.20004, 0.20004 * 0.005);
}

TEST(FormFactor, DifferentialAreaToCoaxialDisc) {
  // The disc as a fan of thin triangles: form factors add over the pieces of a surface.
  for (const auto& [r, h] : {std::pair{1.0, 1.0}, {0.5, 2.0}, {3.0, 0.25}}) {
    const int m = 720;
    double sum = 0.0;
    for (int k = 0; k < m; ++k) {
      const double a0 = 2.0 * std::numbers::pi * k / m, a1 = 2.0 * std::numbers::pi * (k + 1) / m;
      // Circumscribed so that the polygon's area equals the disc's to second order.
      const double rr =
          r * std::sqrt((2.0 * std::numbers::pi / m) / std::sin(2.0 * std::numbers::pi / m));
      sum += pointToTriangleFormFactor(glm::dvec3(0), glm::dvec3(0, 0, 1), {0, 0, h},
                                       {rr * std::cos(a0), rr * std::sin(a0), h},
                                       {rr * std::cos(a1), rr * std::sin(a1), h});
    }
    const double exact = r * r / (h * h + r * r);
    EXPECT_NEAR(sum, exact, exact * 1e-4) << "r " << r << " h " << h;
  }
}

// The fast angle of progressive radiosity's form factors against std::atan2, and the fast
// point-to-polygon form factor against the exact one, on random directions and polygons.
TEST(FormFactor, FastAngleAndPolygonFormFactorMatchTheExactOnes) {
  Rng rng(7, 0);
  double worst_angle = 0.0;
  for (int i = 0; i < 200000; ++i) {
    const double y = std::pow(10.0, -6.0 + 8.0 * rng.uniform());
    const double x = (rng.uniform() - 0.5) * std::pow(10.0, -6.0 + 8.0 * rng.uniform());
    worst_angle = std::max(worst_angle, std::abs(angleFast(y, x) - std::atan2(y, x)));
  }
  EXPECT_EQ(angleFast(0.0, 1.0), 0.0);
  EXPECT_NEAR(angleFast(1.0, 0.0), std::numbers::pi / 2, 1e-12);
  EXPECT_NEAR(angleFast(0.0, -1.0), std::numbers::pi, 1e-12);
  EXPECT_LE(worst_angle, 5e-8);
  double worst_ff = 0.0, worst_relative = 0.0;
  for (int i = 0; i < 20000; ++i) {
    // A random quad 1 to 8 of its sizes away, in front of x (where progressive radiosity uses
    // the polygon form factor; beyond, cancellation in the sum makes the disc the better kernel).
    const double size = 0.05 + rng.uniform(), dist = size * (1.0 + 7.0 * rng.uniform());
    const glm::dvec3 c(rng.uniform() - 0.5, rng.uniform() - 0.5, dist);
    const glm::dvec3 poly[4] = {c, c + glm::dvec3(size, 0, 0.3 * size),
                                c + glm::dvec3(size, size, 0.1 * size), c + glm::dvec3(0, size, 0)};
    const double exact = pointToPolygonFormFactor(glm::dvec3(0), glm::dvec3(0, 0, 1), poly, 4);
    const double fast = pointToPolygonFormFactor<true>(glm::dvec3(0), glm::dvec3(0, 0, 1), poly, 4);
    worst_ff = std::max(worst_ff, std::abs(fast - exact));
    if (exact > 1e-2) worst_relative = std::max(worst_relative, std::abs(fast - exact) / exact);
  }
  // The angles' error is absolute (4e-8 rad), and so is the form factor's (1.2e-8 measured) however
  // small the form factor, so its relative error grows where Lambert's sum cancels (small or
  // grazing polygons); a gather's irradiance, a sum of form factors near 1, moves by 1e-6 at most.
  EXPECT_LE(worst_ff, 1e-7);
  EXPECT_LE(worst_relative, 1e-5);
  std::printf(
      "angleFast: worst %.2e rad; fast form factor: worst absolute %.2e, relative (F > 0.01) "
      "%.2e\n",
      worst_angle, worst_ff, worst_relative);
}

TEST(FormFactor, HorizonClipsWhatIsBelowTheTangentPlane) {
  // A square standing on the receiver's plane through the point, and the same square extended
  // below the plane: the part below must not count.
  const glm::dvec3 x(0.0), n(0, 0, 1);
  const glm::dvec3 above[4] = {{1, -1, 0}, {1, 1, 0}, {1, 1, 1}, {1, -1, 1}};
  const glm::dvec3 straddling[4] = {{1, -1, -1}, {1, 1, -1}, {1, 1, 1}, {1, -1, 1}};
  const double fa = pointToPolygonFormFactor(x, n, above, 4);
  EXPECT_GT(fa, 0.01);
  EXPECT_NEAR(pointToPolygonFormFactor(x, n, straddling, 4), fa, 1e-12);
  // Winding does not matter.
  const glm::dvec3 reversed[4] = {above[3], above[2], above[1], above[0]};
  EXPECT_NEAR(pointToPolygonFormFactor(x, n, reversed, 4), fa, 1e-12);
  // Wholly below: nothing.
  const glm::dvec3 below[3] = {{0, 0, -1}, {1, 0, -1}, {0, 1, -1}};
  EXPECT_EQ(pointToPolygonFormFactor(x, n, below, 3), 0.0);
}

// The furnace (a closed cube) at 400 clusters of the hierarchy: reciprocity A_i F_ij = A_j F_ji
// holds to float rounding (each pair is evaluated once); before the closed-row normalisation the
// rows already sum to 1 within the approximations' error (eq. 2's discs for far pairs, the
// element points' exact form factors near), and with it every row is closed and sums to 1.
TEST(FormFactor, ClosedCubeRowsSumToOneAndReciprocityHolds) {
  Expected<Scene> furnace = builtinScene("furnace");
  ASSERT_TRUE(furnace.ok());
  LightmapResolution res;
  res.elements = 6000;
  Expected<ChartAtlasOptions> ao = lightmapAtlasOptions(*furnace, res);
  ASSERT_TRUE(ao.ok());
  Expected<RadiositySurface> s = RadiositySurface::build(*furnace, *ao, false);
  ASSERT_TRUE(s.ok());
  const std::vector<ClusterRef> cut = s->hierarchy.cut(400);
  ASSERT_GE(cut.size(), 400u);
  // The cube's walls are two-sided: the clusters on the outside see nothing.
  const Bounds3 box = s->bounds;
  const glm::dvec3 centre = 0.5 * (glm::dvec3(box.lo) + glm::dvec3(box.hi));
  std::vector<uint8_t> inside(cut.size());
  size_t inside_count = 0;
  for (size_t i = 0; i < cut.size(); ++i) {
    const ClusterLevel& l = s->hierarchy.level(cut[i].level);
    inside[i] = glm::dot(l.normal[cut[i].index], centre - l.position[cut[i].index]) > 0.0;
    inside_count += inside[i];
  }
  ASSERT_GT(inside_count, 150u);
  double worst_raw = 0.0, mean_raw = 0.0, worst = 0.0, asym = 0.0, total = 0.0;
  for (int probes : {0, 256}) {
    FormFactorOptions fo;
    fo.probe_rays = probes;
    FormFactorStats stats;
    Expected<FormFactorMatrix> f = computeFormFactors(*s, cut, fo, &stats);
    ASSERT_TRUE(f.ok());
    EXPECT_GT(stats.rays, 0u);
    EXPECT_EQ(stats.pairs, uint64_t(cut.size()) * (cut.size() - 1) / 2);
    EXPECT_EQ(stats.closed_rows, probes ? inside_count : 0u);
    for (uint32_t i = 0; i < f->n; ++i) {
      if (!inside[i]) {
        EXPECT_EQ(f->rowSum(i), 0.0);
        continue;
      }
      const double dev = std::fabs(f->rowSum(i) - 1.0);
      if (probes == 0) {
        worst_raw = std::max(worst_raw, dev);
        mean_raw += dev / f->n;
        const double ai = s->hierarchy.level(cut[i].level).area[cut[i].index];
        for (uint32_t j = 0; j < f->n; ++j) {
          const double aj = s->hierarchy.level(cut[j].level).area[cut[j].index];
          asym += std::fabs(ai * (*f)(i, j) - aj * (*f)(j, i));
          total += ai * (*f)(i, j);
        }
      } else {
        worst = std::max(worst, dev);
      }
    }
  }
  std::printf(
      "furnace, %zu clusters inside: raw rows within %.4f of 1 (mean %.4f), asymmetry %.2e\n",
      inside_count, worst_raw, mean_raw, asym / total);
  EXPECT_LT(asym / total, 1e-6);
  EXPECT_LT(mean_raw, 0.02);
  EXPECT_LT(worst_raw, 0.1);
  EXPECT_LT(worst, 1e-5);
}

}  // namespace
}  // namespace penumbra
