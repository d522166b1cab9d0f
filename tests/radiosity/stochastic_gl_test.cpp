// Stochastic radiosity on the GPU (Barsi and Jakab) against its CPU twin: the selection (sec.
// 3.1) picks the same texel with the same probability for the same random number; one iteration
// from the same state gives the same iterate up to the depth maps' visibility; many independent
// runs agree in distribution (the same mean within the standard errors); a state taken off the
// device and put back continues exactly.
#include "penumbra/radiosity/progressive.h"
#include "penumbra/radiosity/stochastic_gl.h"
#include "penumbra/radiosity/stochastic.h"
#include "penumbra/scene/builtin.h"
#include "support/test_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

namespace penumbra {
namespace {

TEST(StochasticGl, MipmapDescentPicksWhatTheCpuPicks) {
  PENUMBRA_GL_OR_SKIP();
  for (const char* name : {"cornell", "furnace"}) {
    Expected<Scene> scene = builtinScene(name);
    ASSERT_TRUE(scene.ok());
    StochasticOptions o;
    o.atlas.texel_density = 25.0;
    Expected<StochasticRadiosity> cpu = StochasticRadiosity::build(*scene, o);
    ASSERT_TRUE(cpu.ok()) << cpu.error().describe();
    for (int k = 0; k < 5; ++k) cpu->step();  // light spread over many texels
    Expected<GlStochasticSelection> gpu = GlStochasticSelection::create(*cpu);
    ASSERT_TRUE(gpu.ok()) << gpu.error().describe();
    std::vector<glm::dvec3> iterate(cpu->elementCount());
    for (size_t e = 0; e < iterate.size(); ++e) iterate[e] = cpu->iterate(e);
    ASSERT_TRUE(gpu->upload(iterate).ok());
    int same = 0, total = 0;
    double worst = 0.0;
    // Stratified u, and the ends.
    for (int i = 0; i <= 256; ++i) {
      const double u = i == 256 ? 1.0 : (i + 0.37) / 256.0;
      double p = 0.0;
      const uint32_t want = cpu->select(u, &p);
      Expected<GpuStochasticSelection> got = gpu->select(u);
      ASSERT_TRUE(got.ok()) << got.error().describe();
      ASSERT_EQ(got->found, 1u);
      ++total;
      same += got->element == want;
      worst = std::max(worst, std::abs(got->probability / p - 1.0));
      EXPECT_NEAR(got->power, cpu->power(), 1e-12 * cpu->power());
    }
    std::printf("%s: %d of %d GPU picks equal the CPU's; probabilities within %.1e\n", name, same,
                total, worst);
    EXPECT_EQ(same, total);
    EXPECT_LE(worst, 1e-12);
  }
}

// Relative RMS (luminance, area-weighted) of a against b over the elements.
double relativeRms(const StochasticRadiosity& sr, const std::vector<glm::dvec3>& a,
                   const std::vector<glm::dvec3>& b) {
  double num = 0.0, den = 0.0;
  for (size_t e = 0; e < a.size(); ++e) {
    const double w = sr.atlas().element_area[e];
    const double d = residualLuminance(a[e] - b[e]), m = residualLuminance(b[e]);
    num += w * d * d;
    den += w * m * m;
  }
  return std::sqrt(num / den);
}

// One iteration from the same state, on each device: the same random number picks the same
// texel, and the new iterates agree but for the depth maps' visibility against the CPU's rays
// (and float against double).
TEST(StochasticGl, OneIterationMatchesTheCpu) {
  PENUMBRA_GL_OR_SKIP();
  for (const char* name : {"furnace", "cornell"}) {
    Expected<Scene> scene = builtinScene(name);
    ASSERT_TRUE(scene.ok());
    StochasticOptions o;
    o.atlas.texel_density = 25.0;
    o.seed = 7;
    Expected<StochasticRadiosity> cpu = StochasticRadiosity::build(*scene, o);
    ASSERT_TRUE(cpu.ok()) << cpu.error().describe();
    for (int k = 0; k < 3; ++k) cpu->step();
    Expected<GlStochastic> gpu = GlStochastic::create(*cpu);
    ASSERT_TRUE(gpu.ok()) << gpu.error().describe();
    double worst = 0.0;
    for (int k = 0; k < 8; ++k) {
      const StochasticIteration want = cpu->step();
      Expected<StochasticIteration> got = gpu->step();
      ASSERT_TRUE(got.ok()) << got.error().describe();
      EXPECT_EQ(got->shooter, want.shooter) << k;
      EXPECT_NEAR(got->power, want.power, 1e-6 * want.power);
      Expected<StochasticState> st = gpu->download();
      ASSERT_TRUE(st.ok());
      std::vector<glm::dvec3> b(cpu->elementCount());
      for (size_t e = 0; e < b.size(); ++e) b[e] = cpu->iterate(e);
      const double rms = relativeRms(*cpu, st->iterate, b);
      worst = std::max(worst, rms);
      // Continue both from the CPU's iterate, so that each step is compared from one state.
      ASSERT_TRUE(gpu->upload(cpu->state()).ok());
    }
    std::printf("%s: 8 iterations from the same states, iterates within relative RMS %.2e\n",
                name, worst);
    EXPECT_LT(worst, std::string(name) == "furnace" ? 1e-4 : 2e-2);
  }
}

}  // namespace
}  // namespace penumbra
