// The dipole through hierarchical links (the sss method) against the transport it approximates:
// the path tracer's random walk in the same medium behind the same smooth boundary. The built-in
// bunny in marble under an area light from behind and a dim sky (point lights cannot reach a
// random walk through a smooth boundary, so the comparison needs emitters the path tracer can
// find), seen without the boundary's specular reflection (which the dipole does not model).
// PENUMBRA_TEST_OUTPUT_DIR=dir renders at 160 x 160 instead of 48 x 48 and writes both images
// and their difference side by side there (sss_compare.png, the picture in docs/algorithms.md).
#include "penumbra/io/image_io.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/raytrace/camera_rays.h"
#include "penumbra/raytrace/path_tracer.h"
#include "penumbra/render/sss_frames.h"
#include "penumbra/subsurface/sss.h"
#include "support/sss_scenes.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace penumbra {
namespace {

TEST(SssReference, BunnyAgreesWithThePathTracersRandomWalk) {
  const Scene scene = test::areaLitBunny();
  const char* output = std::getenv("PENUMBRA_TEST_OUTPUT_DIR");
  const int kSize = output ? 160 : 48;
  SssOptions o;
  o.resolution = LightmapResolution{std::nullopt, 128};
  Expected<SssSolver> solver = SssSolver::build(scene, o);
  ASSERT_TRUE(solver.ok()) << solver.error().describe();
  SssViewSettings view;
  view.width = view.height = kSize;
  view.spp = 4;
  Expected<SssFrames> frames = SssFrames::create(*solver, *scene.camera, view, false);
  ASSERT_TRUE(frames.ok());
  Expected<SssFrame> dipole = frames->render(scene.lights);
  ASSERT_TRUE(dipole.ok());

  PathTracerSettings pt;
  pt.width = pt.height = kSize;
  pt.spp = 64;
  pt.seed = 7;
  pt.boundary_reflection_from_camera = false;
  const PathTracer tracer(scene);
  PathTracerStats stats;
  const Image reference = tracer.render(*scene.camera, pt, &stats);

  // Pixels whose centre ray meets the bunny (not the sky, not the light).
  const CameraRays rays(*scene.camera, kSize, kSize);
  double sum_d = 0.0, sum_r = 0.0, sum_r2 = 0.0;
  int count = 0;
  Image difference(kSize, kSize);
  for (int y = 0; y < kSize; ++y) {
    for (int x = 0; x < kSize; ++x) {
      const Hit hit = solver->surface().engine.intersect(rays.ray(x + 0.5f, y + 0.5f));
      if (!hit.hit() ||
          !scene.materials[solver->surface().flat.material_ids[size_t(hit.triangle)]].subsurface) {
        continue;
      }
      const size_t i = size_t(y) * kSize + size_t(x);
      const glm::vec3 d = dipole->image.pixels[i], r = reference.pixels[i];
      const double ld = (d.x + d.y + d.z) / 3.0, lr = (r.x + r.y + r.z) / 3.0;
      sum_d += ld;
      sum_r += lr;
      sum_r2 += lr * lr;
      difference.pixels[i] = glm::vec3(float(ld - lr) > 0.0f ? float(ld - lr) : 0.0f, 0.0f,
                                       float(lr - ld) > 0.0f ? float(lr - ld) : 0.0f);
      ++count;
    }
  }
  ASSERT_GT(count, 200);
  const double mean_d = sum_d / count, mean_r = sum_r / count;
  std::printf(
      "bunny, %d pixels: dipole mean %.5f, path tracer mean %.5f (ratio %.3f); path "
      "tracer %.1f s, %llu rays\n",
      count, mean_d, mean_r, mean_d / mean_r, stats.seconds,
      static_cast<unsigned long long>(stats.rays));
  if (output) {
    // Side by side at one exposure (the path tracer's mean at 1 - 1/e): the dipole, the random
    // walk, and their difference 4 times brighter (red where the dipole is brighter, blue where
    // it is darker).
    Image panels(3 * kSize, kSize);
    for (int y = 0; y < kSize; ++y) {
      for (int x = 0; x < kSize; ++x) {
        const size_t i = size_t(y) * size_t(kSize) + size_t(x);
        const size_t row = size_t(y) * size_t(3 * kSize);
        panels.pixels[row + size_t(x)] = dipole->image.pixels[i];
        panels.pixels[row + size_t(kSize + x)] = reference.pixels[i];
        panels.pixels[row + size_t(2 * kSize + x)] = 4.0f * difference.pixels[i];
      }
    }
    ToneMapSettings t;
    t.op = ToneMapOperator::kExposure;
    t.exposure_stops = float(std::log2(1.0 / mean_r));
    EXPECT_TRUE(writeImage(std::string(output) + "/sss_compare.png", panels, t).ok());
  }
  // The dipole (eq. 6-8) is darker than the transport it approximates, here by 29%: its R_d is
  // a semi-infinite half-space's, which keeps the light that wanders deep (13% of it for
  // marble's alpha' = 0.999), where the bunny, a nearly lossless finite body, gives it back
  // elsewhere and carries light from the lamp behind through its body; and pass 1 sees only
  // direct light, not what the bunny's parts send each other. Measured the same (ratio 0.60 to
  // 0.74) for skin1, apple, ketchup, cream and potato (docs/algorithms.md). Asserted: darker,
  // by less than 40%.
  EXPECT_LT(mean_d / mean_r, 1.0);
  EXPECT_GT(mean_d / mean_r, 0.6);
}

}  // namespace
}  // namespace penumbra
