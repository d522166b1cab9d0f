// Progressive radiosity (Wallner sec. 2-3) against the reference path tracer: the Cornell box
// rendered from its camera through the lightmap (bilinear lookups, as a lightmapped scene is
// displayed) against the path-traced image of the same camera.
#include "penumbra/geometry/chart_atlas.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/radiosity/progressive.h"
#include "penumbra/raytrace/path_tracer.h"
#include "penumbra/render/lightmap_view.h"
#include "penumbra/scene/builtin.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

namespace penumbra {
namespace {

double luminance(const glm::vec3& c) {
  return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
}

// sqrt(sum |a - b|^2 / sum |b|^2) over the pixels where `lit` is set (RGB).
double relativeRms(const Image& a, const Image& b, const std::vector<uint8_t>& lit) {
  double num = 0.0, den = 0.0;
  for (size_t i = 0; i < a.pixels.size(); ++i) {
    if (!lit[i]) continue;
    for (int c = 0; c < 3; ++c) {
      const double d = double(a.pixels[i][c]) - double(b.pixels[i][c]);
      num += d * d;
      den += double(b.pixels[i][c]) * double(b.pixels[i][c]);
    }
  }
  return std::sqrt(num / den);
}

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
  LightmapViewSettings view;
  view.width = view.height = kSize;
  view.spp = 1024;  // antialiasing as converged as the reference's along edges
  const Image radiosity = renderLightmapView(pr->triangles().positions, pr->triangles().triangles,
                                             pr->atlas(), pr->radianceImage(), camera, view);

  // The reference, and a second one with other random numbers to measure its own noise.
  const PathTracer tracer(*cornell);
  PathTracerSettings pt;
  pt.width = pt.height = kSize;
  pt.spp = 2048;
  const Image reference = tracer.render(camera, pt);
  pt.seed = 1;
  const Image reference2 = tracer.render(camera, pt);

  // Lit pixels: those the reference sees lit (luminance above 1e-3) and that do not see the
  // light itself (radiance 17 against at most 0.6 on the walls: the light's outline, where
  // antialiasing decides, would swamp every other pixel).
  std::vector<uint8_t> lit(reference.pixels.size(), 0);
  size_t lit_count = 0;
  for (size_t i = 0; i < lit.size(); ++i) {
    const double l = luminance(reference.pixels[i]);
    lit[i] = l > 1e-3 && l < 1.0;
    lit_count += lit[i];
  }
  const double error = relativeRms(radiosity, reference, lit);
  const double noise = relativeRms(reference2, reference, lit) / std::sqrt(2.0);
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
TEST(ProgressiveRadiosity, RoomAgreesWithThePathTracer) {
  Expected<Scene> room = loadScene(std::string(PENUMBRA_TEST_DATA) + "/../../scenes/room.json");
  ASSERT_TRUE(room.ok()) << room.error().describe();
  const Camera camera = *room->camera;
  constexpr int kWidth = 64, kHeight = 48, kBlock = 4;

  ProgressiveOptions o;
  o.atlas.texel_density = std::sqrt(20000.0 / faceArea(*room));
  o.convergence = 1e-3;
  o.max_iterations = 2000;
  Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(*room, o);
  ASSERT_TRUE(pr.ok()) << pr.error().describe();
  const ProgressiveStats st = pr->solve();
  ASSERT_TRUE(st.converged);
  LightmapViewSettings view;
  view.width = kWidth;
  view.height = kHeight;
  view.spp = 16;
  const Image radiosity = renderLightmapView(pr->triangles().positions, pr->triangles().triangles,
                                             pr->atlas(), pr->radianceImage(), camera, view);
  const PathTracer tracer(*room);
  PathTracerSettings pt;
  pt.width = kWidth;
  pt.height = kHeight;
  pt.spp = 4096;
  const Image reference = tracer.render(camera, pt);

  glm::dvec3 mean_r(0.0), mean_p(0.0);
  for (size_t i = 0; i < reference.pixels.size(); ++i) {
    mean_r += glm::dvec3(radiosity.pixels[i]);
    mean_p += glm::dvec3(reference.pixels[i]);
  }
  // Blocks: their mean radiance, without the blocks holding a pixel that sees the panel
  // (radiance 9-12 against at most 1 elsewhere).
  double num = 0.0, den = 0.0;
  size_t blocks = 0;
  for (int by = 0; by < kHeight / kBlock; ++by) {
    for (int bx = 0; bx < kWidth / kBlock; ++bx) {
      glm::dvec3 a(0.0), b(0.0);
      bool emitter = false;
      for (int y = by * kBlock; y < (by + 1) * kBlock; ++y) {
        for (int x = bx * kBlock; x < (bx + 1) * kBlock; ++x) {
          const size_t i = size_t(y) * kWidth + size_t(x);
          a += glm::dvec3(radiosity.pixels[i]);
          b += glm::dvec3(reference.pixels[i]);
          emitter = emitter || luminance(reference.pixels[i]) > 3.0;
        }
      }
      if (emitter) continue;
      ++blocks;
      for (int c = 0; c < 3; ++c) {
        num += (a[c] - b[c]) * (a[c] - b[c]);
        den += b[c] * b[c];
      }
    }
  }
  const double block_rms = std::sqrt(num / den);
  const EnergyBalance& books = pr->balance();
  std::printf(
      "room %dx%d: %zu elements, %d iterations, %.1f s; mean radiance / path tracer's (%.4f "
      "%.4f %.4f); %zu blocks of 4 x 4, relative RMS %.4f; escaped %.1e of emitted\n",
      kWidth, kHeight, pr->elementCount(), st.iterations, st.seconds, mean_r.x / mean_p.x,
      mean_r.y / mean_p.y, mean_r.z / mean_p.z, blocks, block_rms,
      books.escaped.x / books.emitted.x);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(mean_r[c] / mean_p[c], 1.0, 0.02);
  EXPECT_GT(blocks, 150u);
  EXPECT_LE(block_rms, 0.05);
  EXPECT_LE(std::abs(books.escaped.x) / books.emitted.x, 1e-6);
}

}  // namespace
}  // namespace penumbra
