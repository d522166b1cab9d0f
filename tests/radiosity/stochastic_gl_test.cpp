// Stochastic radiosity's shooter selection on the GPU (Barsi and Jakab sec. 3.1) against the CPU
// twin (StochasticRadiosity::select): the mipmap built and descended on the device picks the
// same texel with the same probability for the same random number.
#include "penumbra/radiosity/stochastic_gl.h"
#include "penumbra/radiosity/stochastic.h"
#include "penumbra/scene/builtin.h"
#include "support/test_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

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

}  // namespace
}  // namespace penumbra
