#include "support/stochastic_runs.h"

#include "penumbra/radiosity/progressive.h"
#include "penumbra/scene/builtin.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>

namespace penumbra {

ChartMeans stochasticChartMeans(const std::string& name, StochasticOptions o, int first, int runs,
                                int averaged, const StochasticSolve& solve) {
  Expected<Scene> scene = builtinScene(name);
  EXPECT_TRUE(scene.ok());
  std::vector<std::vector<double>> per_run;
  for (int seed = first; seed < first + runs; ++seed) {
    o.seed = uint64_t(seed);
    o.iterations = 0;
    Expected<StochasticRadiosity> sr = StochasticRadiosity::build(*scene, o);
    EXPECT_TRUE(sr.ok()) << sr.error().describe();
    o.iterations = sr->burnIn() + averaged;
    sr = StochasticRadiosity::build(*scene, o);
    const std::vector<glm::dvec3> b = solve(*sr);
    const size_t nc = sr->atlas().chartCount();
    std::vector<double> sum(nc, 0.0), area(nc, 0.0);
    for (size_t e = 0; e < b.size(); ++e) {
      const uint32_t c = sr->atlas().element_chart[e];
      sum[c] += residualLuminance(b[e]) * sr->atlas().element_area[e];
      area[c] += sr->atlas().element_area[e];
    }
    per_run.resize(nc);
    for (size_t c = 0; c < nc; ++c) per_run[c].push_back(sum[c] / area[c]);
  }
  ChartMeans m;
  for (const std::vector<double>& x : per_run) {
    double mean = 0.0, var = 0.0;
    for (double v : x) mean += v;
    mean /= runs;
    for (double v : x) var += (v - mean) * (v - mean);
    m.mean.push_back(mean);
    m.standard_error.push_back(std::sqrt(var / (runs - 1) / runs));
  }
  return m;
}

void expectFurnaceClosedForm(const ChartMeans& m, double largest_standard_error,
                             const std::string& label) {
  const double want = 2.0 * std::numbers::pi;
  int inside = 0;
  for (size_t c = 0; c < m.mean.size(); ++c) {
    if (m.mean[c] < 1.0) continue;  // the cube's outside: nothing reaches it
    ++inside;
    const double z = (m.mean[c] - want) / m.standard_error[c];
    std::printf("%s, face %zu: %.4f (2 pi = %.4f), standard error %.4f, z %.2f\n", label.c_str(), c,
                m.mean[c], want, m.standard_error[c], z);
    EXPECT_LT(std::abs(z), 4.0) << label << " face " << c;
    EXPECT_LT(m.standard_error[c], largest_standard_error * want) << label << " face " << c;
  }
  EXPECT_EQ(inside, 6) << label;
}

Scene lampOverFloorScene() {
  Scene s;
  s.source = "test:lamp";
  s.materials = {{"floor", glm::vec3(0.5f), glm::vec3(0.0f)},
                 {"lamp", glm::vec3(0.0f), glm::vec3(3.0f)}};
  Mesh floor;
  floor.name = "floor";
  floor.positions = {{-2, 0, -2}, {-2, 0, 2}, {2, 0, 2}, {2, 0, -2}};
  floor.triangles = {{0, 1, 2}, {0, 2, 3}};
  floor.material_ids = {0, 0};
  Mesh lamp;
  lamp.name = "lamp";
  lamp.positions = {{-0.5f, 1, -0.5f}, {0.5f, 1, -0.5f}, {0.5f, 1, 0.5f}, {-0.5f, 1, 0.5f}};
  lamp.triangles = {{0, 1, 2}, {0, 2, 3}};
  lamp.material_ids = {1, 1};
  s.meshes = {floor, lamp};
  return s;
}

double relativeRmsError(const StochasticRadiosity& sr, const std::vector<glm::dvec3>& reference) {
  double num = 0.0, den = 0.0;
  for (size_t e = 0; e < sr.elementCount(); ++e) {
    const double a = sr.atlas().element_area[e];
    const double x = residualLuminance(sr.radiosity(e)), y = residualLuminance(reference[e]);
    num += a * (x - y) * (x - y);
    den += a * y * y;
  }
  return std::sqrt(num / den);
}

}  // namespace penumbra
