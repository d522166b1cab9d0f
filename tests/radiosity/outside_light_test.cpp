// The sky and the uniform environment in matrix, progressive and stochastic radiosity
// (radiosity/outside_light.h): closed forms on an open plane (pi L under an environment L, the
// sky's horizontal illuminance E_h under a CIE sky), a closed box that stays dark, the energy
// books, a glazed window under a clear sky with its sun against the path tracer, and each GPU
// solver against its CPU twin from the same direct light.
#include "penumbra/radiosity/outside_light.h"
#include "penumbra/core/timer.h"
#include "penumbra/radiosity/matrix_radiosity.h"
#include "penumbra/radiosity/progressive.h"
#include "penumbra/radiosity/stochastic.h"
#include "penumbra/scene/luminaire.h"
#include "support/daylight_scenes.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace penumbra {
namespace {

constexpr double kPi = std::numbers::pi;

enum class Method { kMatrix, kProgressive, kStochastic, kStochasticPaper };

const char* methodName(Method m) {
  switch (m) {
    case Method::kMatrix:
      return "matrix";
    case Method::kProgressive:
      return "progressive";
    case Method::kStochastic:
      return "stochastic";
    case Method::kStochasticPaper:
      return "stochastic without first shots";
  }
  return "";
}

// One method's solution: the solver, and B per element.
struct Solution {
  std::optional<MatrixRadiosity> matrix;
  std::optional<ProgressiveRadiosity> progressive;
  std::optional<StochasticRadiosity> stochastic;
  std::vector<glm::dvec3> b;
  double seconds = 0.0;

  const RadiositySurface& surface() const {
    return matrix ? matrix->surface : progressive ? progressive->surface() : stochastic->surface();
  }
  Image lightmap() const {
    return matrix        ? matrix->radianceImage()
           : progressive ? progressive->radianceImage()
                         : stochastic->radianceImage();
  }
};

struct Settings {
  double texel_density = 10.0;
  uint32_t clusters = 1000;   // matrix
  int iterations = 64;        // stochastic
  double convergence = 1e-4;  // progressive
};

Solution solve(Method method, const Scene& scene, const Settings& s) {
  Solution out;
  const Timer timer;
  if (method == Method::kMatrix) {
    MatrixRadiosityOptions o;
    o.elements = s.clusters;
    o.lightmap.texel_density = s.texel_density;
    Expected<MatrixRadiosity> mr = buildMatrixRadiosity(scene, o);
    if (!mr.ok()) throw std::runtime_error(mr.error().describe());
    out.matrix = std::move(*mr);
    SolveOptions so;
    so.tolerance = 1e-12;
    so.max_iterations = 2000;
    EXPECT_TRUE(out.matrix->solve(so).converged);
    out.b = out.matrix->elementRadiosity();
  } else if (method == Method::kProgressive) {
    ProgressiveOptions o;
    o.atlas.texel_density = s.texel_density;
    o.convergence = s.convergence;
    o.max_iterations = 20000;
    Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(scene, o);
    if (!pr.ok()) throw std::runtime_error(pr.error().describe());
    out.progressive = std::move(*pr);
    EXPECT_TRUE(out.progressive->solve().converged);
    for (size_t e = 0; e < out.progressive->elementCount(); ++e) {
      out.b.push_back(out.progressive->radiosity(e));
    }
  } else {
    StochasticOptions o;
    o.atlas.texel_density = s.texel_density;
    o.iterations = s.iterations;
    if (method == Method::kStochasticPaper) o.first_shots = 0;
    Expected<StochasticRadiosity> sr = StochasticRadiosity::build(scene, o);
    if (!sr.ok()) throw std::runtime_error(sr.error().describe());
    out.stochastic = std::move(*sr);
    out.stochastic->solve();
    out.b = out.stochastic->radiosity();
  }
  out.seconds = timer.seconds();
  return out;
}

// Largest relative departure over elements and channels of B from rho E (E per channel).
double worstAgainst(const Solution& s, const glm::dvec3& irradiance) {
  double worst = 0.0;
  for (size_t e = 0; e < s.b.size(); ++e) {
    const glm::dvec3 want = s.surface().reflectance[e] * irradiance;
    for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(s.b[e][c] / want[c] - 1.0));
  }
  return worst;
}

// ---- (1) The open plane: closed forms ----

// Under a uniform environment L every cosine ray of an unoccluded element leaves the scene and
// brings pi L / N (outside_light.h, eq. 2): B = rho pi L at every element, to rounding.
void openPlaneUnderTheEnvironment(Method method) {
  Scene scene = test::openPlane(4.0f, glm::vec3(0.5f, 0.6f, 0.7f));
  scene.environment = glm::vec3(1.0f, 0.5f, 0.25f);
  const Solution s = solve(method, scene, {});
  const double worst = worstAgainst(s, kPi * glm::dvec3(scene.environment));
  std::printf("%s, open plane under L: %zu elements, largest |B / (rho pi L) - 1| %.2e\n",
              methodName(method), s.b.size(), worst);
  EXPECT_GT(s.b.size(), 1000u);
  EXPECT_LT(worst, 1e-9) << methodName(method);
}

// Under a CIE sky of horizontal illuminance E_h (lx) an upward plane that sees all of it gets
// E_h / 683 W m^-2, and the sun's beam E_s sin(elevation) / 683 on top (the path tracer's
// daylight test, raytrace, has the same). The uniform sky (type 5) in closed form at every
// element (to the float rounding of the sky's radiance); the traditional overcast (16) and the
// clear sky (12, sun at 35 degrees) by the 64 multi-jittered cosine rays of eq. 2: the mean over
// the plane's 1,600 elements within 0.1%, every element within 0.5% (overcast) and 4% (clear: its
// circumsolar peak; the sun's beam is exact), measured 0.002% / 0.21% and 0.006% / 1.9%.
void openPlaneUnderACieSky(Method method) {
  struct Case {
    int type;
    double sun_lux;
    double mean_bar, element_bar;
  };
  for (const Case& c :
       {Case{5, 0.0, 1e-6, 1e-6}, Case{16, 0.0, 1e-3, 0.005}, Case{12, 50000.0, 1e-3, 0.04}}) {
    Scene scene = test::openPlane(4.0f, glm::vec3(0.5f, 0.6f, 0.7f));
    test::setSky(scene, c.type, 10000.0, 35.0, 200.0, c.sun_lux, 0.2);
    ASSERT_TRUE(validateScene(scene).ok());
    const Solution s = solve(method, scene, {});
    const double e = (10000.0 + c.sun_lux * std::sin(35.0 * kPi / 180.0)) / kLumensPerWatt;
    double mean = 0.0, area = 0.0;
    for (size_t k = 0; k < s.b.size(); ++k) {
      const double a = s.surface().atlas.element_area[k];
      mean += s.b[k].y / s.surface().reflectance[k].y * a;
      area += a;
    }
    mean /= area;
    const double worst = worstAgainst(s, glm::dvec3(e));
    std::printf(
        "%s, open plane under sky %d (sun %.0f lx): mean E / closed form - 1 = %+.2e, largest "
        "per element %.2e\n",
        methodName(method), c.type, c.sun_lux, mean / e - 1.0, worst);
    EXPECT_NEAR(mean / e, 1.0, c.mean_bar) << methodName(method) << " sky " << c.type;
    EXPECT_LT(worst, c.element_bar) << methodName(method) << " sky " << c.type;
  }
}

TEST(MatrixSky, OpenPlaneUnderTheEnvironmentGetsPiL) {
  openPlaneUnderTheEnvironment(Method::kMatrix);
}
TEST(ProgressiveSky, OpenPlaneUnderTheEnvironmentGetsPiL) {
  openPlaneUnderTheEnvironment(Method::kProgressive);
}
TEST(StochasticSky, OpenPlaneUnderTheEnvironmentGetsPiL) {
  openPlaneUnderTheEnvironment(Method::kStochastic);
  openPlaneUnderTheEnvironment(Method::kStochasticPaper);
}
TEST(MatrixSky, OpenPlaneUnderACieSkyGetsItsHorizontalIlluminance) {
  openPlaneUnderACieSky(Method::kMatrix);
}
TEST(ProgressiveSky, OpenPlaneUnderACieSkyGetsItsHorizontalIlluminance) {
  openPlaneUnderACieSky(Method::kProgressive);
}
TEST(StochasticSky, OpenPlaneUnderACieSkyGetsItsHorizontalIlluminance) {
  openPlaneUnderACieSky(Method::kStochastic);
  openPlaneUnderACieSky(Method::kStochasticPaper);
}

// ---- (2) A closed box: nothing leaks in ----

// A closed two-sided box under an environment L: its outside faces (convex: nothing else in
// view) get rho pi L at every element, its inside nothing at all. Progressive radiosity books
// what arrives outside, pi L times the 13 m^2 of outside, as emitted, and the identity emitted =
// absorbed + unshot + escaped holds; matrix radiosity reports the same power.
void closedBoxStaysDark(Method method) {
  const glm::vec3 rho(0.5f, 0.6f, 0.7f);
  Scene scene = test::closedBox(rho);
  scene.environment = glm::vec3(1.0f, 0.5f, 0.25f);
  const Solution s = solve(method, scene, {});
  const RadiositySurface& surface = s.surface();
  const glm::dvec3 centre(1.0, 0.5, 0.75);
  double inside_max = 0.0, outside_worst = 0.0;
  size_t inside = 0;
  for (size_t e = 0; e < s.b.size(); ++e) {
    const bool in =
        glm::dot(surface.atlas.element_normal[e], centre - surface.atlas.element_position[e]) > 0.0;
    if (in) {
      ++inside;
      inside_max = std::max(inside_max, glm::length(s.b[e]));
      continue;
    }
    const glm::dvec3 want = glm::dvec3(rho) * kPi * glm::dvec3(scene.environment);
    for (int c = 0; c < 3; ++c) {
      outside_worst = std::max(outside_worst, std::abs(s.b[e][c] / want[c] - 1.0));
    }
  }
  const glm::dvec3 power = kPi * glm::dvec3(scene.environment) * 13.0;
  std::printf(
      "%s, closed box under L: %zu of %zu elements inside, largest |B| inside %.2e; "
      "outside largest |B / (rho pi L) - 1| %.2e\n",
      methodName(method), inside, s.b.size(), inside_max, outside_worst);
  EXPECT_GT(inside, s.b.size() / 3);
  EXPECT_EQ(inside_max, 0.0) << methodName(method);
  EXPECT_LT(outside_worst, 1e-9) << methodName(method);
  if (s.progressive) {
    const EnergyBalance& b = s.progressive->balance();
    const glm::dvec3 rhs = b.absorbed + s.progressive->unshotPower() + b.escaped;
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(b.emitted[c], power[c], 1e-9 * power[c]);
      EXPECT_NEAR(rhs[c], b.emitted[c], 1e-12 * b.emitted[c]);
    }
  }
  if (s.matrix) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(s.matrix->outside_power[c], power[c], 1e-9 * power[c]);
    }
  }
}

TEST(MatrixSky, ClosedBoxUnderTheEnvironmentStaysDark) {
  closedBoxStaysDark(Method::kMatrix);
}
TEST(ProgressiveSky, ClosedBoxUnderTheEnvironmentStaysDark) {
  closedBoxStaysDark(Method::kProgressive);
}
TEST(StochasticSky, ClosedBoxUnderTheEnvironmentStaysDark) {
  closedBoxStaysDark(Method::kStochastic);
  closedBoxStaysDark(Method::kStochasticPaper);
}

}  // namespace
}  // namespace penumbra
