// Progressive radiosity (Wallner sec. 2-3) against the reference path tracer: the Cornell box
// and the room of scenes/room.json rendered from their cameras through the lightmap (bilinear
// lookups, as a lightmapped scene is displayed) against the path-traced images of the same
// cameras (shared with the matrix method's tests).
#include "penumbra/io/scene_io.h"
#include "penumbra/radiosity/progressive.h"
#include "penumbra/scene/builtin.h"
#include "support/image_compare.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

namespace penumbra {
namespace {

TEST(ProgressiveRadiosity, CornellImageAgreesWithThePathTracer) {
  Expected<Scene> cornell = builtinScene("cornell");
  ASSERT_TRUE(cornell.ok());
  const Camera camera = *cornell->camera;
  constexpr int kSize = 64;

  ProgressiveOptions o;
  o.atlas.texel_density = 80.0;  // 1.25 cm texels
  o.convergence = 1e-3;
  o.max_iterations = 2000;
  Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(*cornell, o);
  ASSERT_TRUE(pr.ok()) << pr.error().describe();
  const ProgressiveStats st = pr->solve();
  ASSERT_TRUE(st.converged);
  // 1024 rays per pixel: antialiasing as converged as the reference's along edges.
  const Image radiosity = test::lightmapView(pr->triangles(), pr->atlas(), pr->radianceImage(),
                                             camera, kSize, kSize, 1024);

  // The reference, and a second one with other random numbers to measure its own noise.
  const Image& reference =
      test::pathTracedReference("cornell64", *cornell, camera, kSize, kSize, 2048);
  const Image& reference2 =
      test::pathTracedReference("cornell64", *cornell, camera, kSize, kSize, 2048, 1);
  // Lit pixels that do not see the light (radiance 17 against at most 0.6 on the walls).
  const std::vector<uint8_t> lit = test::litPixels(reference, 1.0);
  size_t lit_count = 0;
  for (uint8_t l : lit) lit_count += l;
  const double error = test::relativeRms(radiosity, reference, lit);
  const double noise = test::relativeRms(reference2, reference, lit) / std::sqrt(2.0);
  std::printf(
      "cornell %dx%d: %zu elements, %d iterations, %.2f s; %zu lit pixels; relative RMS "
      "progressive vs path tracer %.4f (path tracer's own noise %.4f)\n",
      kSize, kSize, pr->elementCount(), st.iterations, st.seconds, lit_count, error, noise);
  EXPECT_GT(lit_count, size_t(kSize * kSize * 9 / 10));
  // Issue 5's bar. Measured 2.9-3.5%, of which the path tracer's own noise is 1.9%.
  EXPECT_LE(error, 0.05);
}

// The room of scenes/room.json as an exported model comes: walls of single quads, one wound
// facing out of the room, two-sided paint, the bunny scan (69,451 triangles) as a statue, a
// teapot on a box, an emissive panel and a point light. The bars: mean radiance within
// 2% of the path tracer (>= 4096 spp) and relative RMS over 4 x 4-pixel block averages within
// 5%, leaving out blocks with pixels that see the emitter; in a closed room nothing escapes.
void roomAgreesWithThePathTracer(bool adaptive) {
  Expected<Scene> room = loadScene(std::string(PENUMBRA_TEST_DATA) + "/../../scenes/room.json");
  ASSERT_TRUE(room.ok()) << room.error().describe();
  const Camera camera = *room->camera;
  constexpr int kWidth = 64, kHeight = 48;

  ProgressiveOptions o;
  o.atlas.texel_density = texelDensityFor(*room, 20000);
  o.convergence = 1e-3;
  o.max_iterations = 2000;
  o.adaptive = adaptive;
  Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(*room, o);
  ASSERT_TRUE(pr.ok()) << pr.error().describe();
  const ProgressiveStats st = pr->solve();
  ASSERT_TRUE(st.converged);
  const Image radiosity = test::lightmapView(pr->triangles(), pr->atlas(), pr->radianceImage(),
                                             camera, kWidth, kHeight, 16);
  const Image& reference =
      test::pathTracedReference("room64x48", *room, camera, kWidth, kHeight, 4096);
  // Blocks holding a pixel that sees the panel (radiance 9-12 against at most 1 elsewhere) are
  // left out.
  const test::BlockComparison b = test::compareBlocks(radiosity, reference, 4, 3.0);
  const EnergyBalance& books = pr->balance();
  std::printf(
      "room %dx%d: %zu elements, %zu receivers (%u split), %d iterations, %.1f s; mean radiance "
      "/ path tracer's (%.4f %.4f %.4f); %zu blocks of 4 x 4, relative RMS %.4f; escaped %.1e "
      "of emitted\n",
      kWidth, kHeight, pr->elementCount(), pr->receivers().size(), st.refined, st.iterations,
      st.seconds, b.mean_ratio.x, b.mean_ratio.y, b.mean_ratio.z, b.blocks, b.block_rms,
      books.escaped.x / books.emitted.x);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(b.mean_ratio[c], 1.0, 0.02);
  EXPECT_GT(b.blocks, 150u);
  EXPECT_LE(b.block_rms, 0.05);
  EXPECT_LE(std::abs(books.escaped.x) / books.emitted.x, 1e-6);
}

TEST(ProgressiveRadiosity, RoomAgreesWithThePathTracer) {
  roomAgreesWithThePathTracer(false);
}

// The same bars with adaptive receivers (Wallner sec. 4) from 4 x 4 texels: the scan's charts,
// the two-triangle walls, the wall wound outwards and the point light's shadows.
TEST(ProgressiveRadiosity, RoomWithAdaptiveReceiversAgreesWithThePathTracer) {
  roomAgreesWithThePathTracer(true);
}

}  // namespace
}  // namespace penumbra
