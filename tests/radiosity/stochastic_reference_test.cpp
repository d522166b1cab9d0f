// Stochastic radiosity (Barsi and Jakab) against the reference path tracer on the room of
// scenes/room.json, the scene that real exports are made of (single-quad walls, one wound
// outwards, two-sided paint, the 69,451-triangle bunny scan, a teapot, an emissive panel and a
// point light): the same bars as progressive radiosity's (mean radiance within 2%, relative RMS
// over 4 x 4-pixel blocks within 5%, blocks that see the panel left out), at the solver's default
// iterations and first shots.
#include "penumbra/io/scene_io.h"
#include "penumbra/radiosity/stochastic.h"
#include "support/image_compare.h"

#include <gtest/gtest.h>

#include <cstdio>

namespace penumbra {
namespace {

TEST(StochasticRadiosity, RoomAgreesWithThePathTracer) {
  Expected<Scene> room = loadScene(std::string(PENUMBRA_TEST_DATA) + "/../../scenes/room.json");
  ASSERT_TRUE(room.ok()) << room.error().describe();
  const Camera camera = *room->camera;
  constexpr int kWidth = 64, kHeight = 48;
  StochasticOptions o;
  o.atlas.texel_density = texelDensityFor(*room, 20000);
  ASSERT_EQ(o.iterations, 1000);  // the default
  Expected<StochasticRadiosity> sr = StochasticRadiosity::build(*room, o);
  ASSERT_TRUE(sr.ok()) << sr.error().describe();
  const StochasticStats st = sr->solve();
  const Image view = test::lightmapView(sr->triangles(), sr->atlas(), sr->radianceImage(), camera,
                                        kWidth, kHeight, 16);
  const Image& reference =
      test::pathTracedReference("room64x48", *room, camera, kWidth, kHeight, 4096);
  const test::BlockComparison b = test::compareBlocks(view, reference, 4, 3.0);
  std::printf(
      "room %dx%d: %zu texels, %d iterations (burn-in %d), %.1f s, estimated error %.4f; mean "
      "radiance / path tracer's (%.4f %.4f %.4f); %zu blocks of 4 x 4, relative RMS %.4f\n",
      kWidth, kHeight, sr->elementCount(), st.total_iterations, sr->burnIn(), st.seconds, st.error,
      b.mean_ratio.x, b.mean_ratio.y, b.mean_ratio.z, b.blocks, b.block_rms);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(b.mean_ratio[c], 1.0, 0.02);
  EXPECT_GT(b.blocks, 150u);
  EXPECT_LE(b.block_rms, 0.05);
}

}  // namespace
}  // namespace penumbra
