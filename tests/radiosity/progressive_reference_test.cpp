// Progressive radiosity (Wallner sec. 2-3) against the reference path tracer: the Cornell box
// rendered from its camera through the lightmap (bilinear lookups, as a lightmapped scene is
// displayed) against the path-traced image of the same camera.
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

}  // namespace
}  // namespace penumbra
