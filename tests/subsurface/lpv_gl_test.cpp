// The GPU twin of the SSLPV propagation (subsurface/lpv_gl.h, shaders/subsurface/
// lpv_propagate.comp) against the CPU's (lpvPropagate and LpvSolver's accumulation): the
// accumulated field of the bunny in veined marble (a heterogeneous medium: every cell its own
// transfer factors), and the frames of the animated blobs, whose grids change size and whose
// cells change kind from frame to frame, on both devices.
#include "penumbra/io/scene_io.h"
#include "penumbra/scene/animation.h"
#include "penumbra/subsurface/lpv.h"
#include "penumbra/subsurface/lpv_sh.h"
#include "support/image_compare.h"
#include "support/test_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

namespace penumbra {
namespace {

// max |a - b| over every coefficient of every cell, relative to the largest |b|.
double fieldDifference(const LpvField& a, const LpvField& b) {
  double diff = 0.0, scale = 0.0;
  for (size_t ch = 0; ch < 3; ++ch) {
    EXPECT_EQ(a.c[ch].size(), b.c[ch].size());
    for (size_t i = 0; i < std::min(a.c[ch].size(), b.c[ch].size()); ++i) {
      for (int k = 0; k < 4; ++k) {
        diff = std::max(diff, double(std::abs(a.c[ch][i][k] - b.c[ch][i][k])));
        scale = std::max(scale, double(std::abs(b.c[ch][i][k])));
      }
    }
  }
  return scale > 0.0 ? diff / scale : diff;
}

// The two devices compute the same float operations in the same order: the accumulated fields
// agree to float rounding (the GPU may fuse multiply-adds), 32 steps included.
TEST(LpvGl, PropagationAgreesWithTheCpu) {
  PENUMBRA_GL_OR_SKIP();
  Expected<Scene> scene = loadScene("lpv");
  ASSERT_TRUE(scene.ok());
  for (Material& m : scene->materials) {
    if (m.subsurface) m.subsurface->pattern = "veins";
  }
  for (const int steps : {8, 32}) {
    LpvOptions o;
    o.steps = steps;
    o.rsm_resolution = 128;
    Expected<LpvSolver> cpu = LpvSolver::build(*scene, o);
    Expected<LpvSolver> gpu = LpvSolver::build(*scene, o);
    ASSERT_TRUE(cpu.ok() && gpu.ok());
    ASSERT_TRUE(gpu->useGpu().ok());
    ASSERT_TRUE(cpu->update(*scene).ok());
    Expected<LpvFrameTimes> t = gpu->update(*scene);
    ASSERT_TRUE(t.ok()) << t.error().describe();
    const LpvField& a = gpu->objects()[0].accumulated;
    const LpvField& b = cpu->objects()[0].accumulated;
    const double diff = fieldDifference(a, b);
    const glm::dvec3 fa = a.flux(), fb = b.flux();
    std::printf(
        "%d steps: GPU vs CPU accumulated field, max difference %.2e of the largest "
        "coefficient; flux %.6e vs %.6e W\n",
        steps, diff, fa.x, fb.x);
    EXPECT_LT(diff, 1e-5);
    // Not trivially equal: the field is lit and the medium varies.
    EXPECT_GT(fb.x, 0.0);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(fa[c] / fb[c], 1.0, 1e-5) << c;
  }
}

// The blobs merge (their topology changes) while the light stays: every frame voxelises anew,
// the grid changes size, and the GPU's volumes follow; each frame's image agrees with the CPU's.
TEST(LpvGl, DeformingFramesAgreeWithTheCpu) {
  PENUMBRA_GL_OR_SKIP();
  const std::optional<SceneAnimation> blobs = builtinAnimation("blobs");
  ASSERT_TRUE(blobs.has_value());
  Expected<Scene> first = (*blobs)(0.0);
  ASSERT_TRUE(first.ok());
  LpvOptions o;
  o.rsm_resolution = 128;
  Expected<LpvSolver> cpu = LpvSolver::build(*first, o);
  Expected<LpvSolver> gpu = LpvSolver::build(*first, o);
  ASSERT_TRUE(cpu.ok() && gpu.ok());
  ASSERT_TRUE(gpu->useGpu().ok());
  std::vector<glm::ivec3> sizes;
  for (const double t : {0.0, 0.5, 0.9}) {
    Expected<Scene> scene = (*blobs)(t);
    ASSERT_TRUE(scene.ok());
    ASSERT_TRUE(cpu->update(*scene).ok());
    ASSERT_TRUE(gpu->update(*scene).ok());
    const Image a = gpu->render(*scene, *scene->camera, 48, 36, 1, 0);
    const Image b = cpu->render(*scene, *scene->camera, 48, 36, 1, 0);
    std::vector<uint8_t> mask(b.pixels.size(), 1);
    const double rms = test::relativeRms(a, b, mask);
    double total = 0.0;
    for (const glm::vec3& p : b.pixels) total += p.x + p.y + p.z;
    std::printf(
        "blobs at t = %.1f: %zu triangles, grid %dx%dx%d, GPU vs CPU image %.2e "
        "relative RMS\n",
        t, scene->meshes[0].triangles.size(), cpu->objects()[0].grid.size.x,
        cpu->objects()[0].grid.size.y, cpu->objects()[0].grid.size.z, rms);
    EXPECT_GT(total, 0.0);
    EXPECT_LT(rms, 1e-5);
    sizes.push_back(cpu->objects()[0].grid.size);
  }
  // The grid followed the mesh (the GPU's textures were made anew).
  EXPECT_NE(sizes.front(), sizes.back());
}

}  // namespace
}  // namespace penumbra
