// Matrix radiosity (Carr, Hall, Hart 2003, sec. 3) on clusters of the multiresolution hierarchy
// against the reference path tracer: the Cornell box and the room of scenes/room.json, viewed from
// their cameras through the lightmap, and the paper's Fig. 3 finding (Gauss-Seidel needs about
// half the iterations of Jacobi).
#include "penumbra/core/check.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/radiosity/jacobi_gl.h"
#include "penumbra/radiosity/matrix_radiosity.h"
#include "penumbra/scene/builtin.h"
#include "support/image_compare.h"
#include "support/test_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace penumbra {
namespace {

using test::compareBlocks;
using test::luminance;
using test::pathTracedReference;

Image view(const MatrixRadiosity& mr, const Camera& camera, int width, int height, int spp) {
  return test::lightmapView(mr.surface.flat, mr.surface.atlas, mr.radianceImage(), camera, width,
                            height, spp);
}

TEST(MatrixRadiosity, CornellImageAgreesWithThePathTracer) {
  Expected<Scene> cornell = builtinScene("cornell");
  ASSERT_TRUE(cornell.ok());
  constexpr int kSize = 64;
  MatrixRadiosityOptions o;
  o.elements = 2500;
  Expected<MatrixRadiosity> mr = buildMatrixRadiosity(*cornell, o);
  ASSERT_TRUE(mr.ok()) << mr.error().describe();
  SolveOptions so;
  so.tolerance = 1e-10;
  ASSERT_TRUE(mr->solve(so).converged);
  const Image image = view(*mr, *cornell->camera, kSize, kSize, 1024);
  const Image& reference =
      pathTracedReference("cornell64", *cornell, *cornell->camera, kSize, kSize, 2048);
  // Lit pixels that do not see the light itself (as the progressive method's test).
  const std::vector<uint8_t> lit = test::litPixels(reference, 1.0);
  const double error = test::relativeRms(image, reference, lit);
  const test::BlockComparison blocks = compareBlocks(image, reference, 4, 1.0);
  std::printf(
      "cornell %dx%d: %zu clusters of %zu elements, form factors %.2f s (%llu rays); relative RMS "
      "matrix vs path tracer %.4f per pixel, %.4f over 4 x 4 blocks; mean ratio %.4f %.4f %.4f\n",
      kSize, kSize, mr->size(), mr->surface.elementCount(), mr->form_factor_stats.seconds,
      (unsigned long long)mr->form_factor_stats.rays, error, blocks.block_rms, blocks.mean_ratio.x,
      blocks.mean_ratio.y, blocks.mean_ratio.z);
  EXPECT_LE(error, 0.05);
  EXPECT_LE(blocks.block_rms, 0.05);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(blocks.mean_ratio[c], 1.0, 0.02);
}

// The room as an exported model comes (walls of single quads, one wound outwards, two-sided
// paint, the bunny scan, a teapot, an emissive panel and a point light) at the 5000
// elements: mean radiance within 2% of the path tracer (4096 spp), relative RMS over 4 x 4-pixel
// block averages within 5%, blocks that see the panel left out.
// The room at 5000 clusters, built once for the tests below.
MatrixRadiosity& roomSystem() {
  static MatrixRadiosity mr = [] {
    Expected<Scene> room = loadScene(std::string(PENUMBRA_TEST_DATA) + "/../../scenes/room.json");
    PENUMBRA_CHECK(room.ok());
    MatrixRadiosityOptions o;
    o.elements = 5000;
    Expected<MatrixRadiosity> built = buildMatrixRadiosity(*room, o);
    PENUMBRA_CHECK(built.ok());
    return std::move(*built);
  }();
  return mr;
}

TEST(MatrixRadiosity, RoomAgreesWithThePathTracer) {
  Expected<Scene> room = loadScene(std::string(PENUMBRA_TEST_DATA) + "/../../scenes/room.json");
  ASSERT_TRUE(room.ok()) << room.error().describe();
  constexpr int kWidth = 64, kHeight = 48;
  MatrixRadiosity& mr = roomSystem();
  mr.radiosity.assign(mr.size(), glm::vec3(0.0f));
  SolveOptions so;
  so.tolerance = 1e-8;
  ASSERT_TRUE(mr.solve(so).converged);
  const Image image = view(mr, *room->camera, kWidth, kHeight, 16);
  const Image& reference =
      pathTracedReference("room64x48", *room, *room->camera, kWidth, kHeight, 4096);
  const test::BlockComparison b = compareBlocks(image, reference, 4, 3.0);
  std::printf(
      "room %dx%d: %zu clusters of %zu elements, form factors %.1f s (%llu rays, %llu rows "
      "closed); mean radiance / path tracer's (%.4f %.4f %.4f); %zu blocks of 4 x 4, relative "
      "RMS %.4f\n",
      kWidth, kHeight, mr.size(), mr.surface.elementCount(), mr.form_factor_stats.seconds,
      (unsigned long long)mr.form_factor_stats.rays,
      (unsigned long long)mr.form_factor_stats.closed_rows, b.mean_ratio.x, b.mean_ratio.y,
      b.mean_ratio.z, b.blocks, b.block_rms);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(b.mean_ratio[c], 1.0, 0.02);
  EXPECT_GT(b.blocks, 150u);
  EXPECT_LE(b.block_rms, 0.05);
}

// The GPU's Jacobi (radiosity/jacobi_gl.h) on the room's system: the same solution as the CPU's,
// so the same agreement with the path tracer.
TEST(MatrixRadiosity, RoomOnTheGpuMatchesTheCpu) {
  PENUMBRA_GL_OR_SKIP();
  MatrixRadiosity& mr = roomSystem();
  SolveOptions so;
  so.solver = MatrixSolver::kJacobi;
  so.tolerance = 1e-8;
  mr.radiosity.assign(mr.size(), glm::vec3(0.0f));
  ASSERT_TRUE(mr.solve(so).converged);
  const std::vector<glm::vec3> cpu = mr.radiosity;
  Expected<GlJacobi> gl = GlJacobi::create(*mr.system);
  ASSERT_TRUE(gl.ok()) << gl.error().describe();
  std::vector<glm::vec3> gpu(mr.size(), glm::vec3(0.0f));
  Expected<SolveStats> st = gl->solve(gpu, so);
  ASSERT_TRUE(st.ok()) << st.error().describe();
  ASSERT_TRUE(st->converged);
  double worst = 0.0, peak = 0.0;
  for (size_t k = 0; k < cpu.size(); ++k) {
    for (int c = 0; c < 3; ++c) {
      worst = std::max(worst, double(std::fabs(gpu[k][c] - cpu[k][c])));
      peak = std::max(peak, double(std::fabs(cpu[k][c])));
    }
  }
  std::printf("room on the GPU: %d iterations, largest difference %.2e of the peak\n",
              st->iterations, worst / peak);
  EXPECT_LT(worst / peak, 1e-5);
}

int iterationsTo(const SolveStats& s, double tolerance) {
  for (size_t k = 0; k < s.history.size(); ++k) {
    if (s.history[k] <= tolerance) return int(k);
  }
  return -1;
}

TEST(MatrixRadiosity, GaussSeidelNeedsAboutHalfTheIterationsOfJacobi) {
  Expected<Scene> cornell = builtinScene("cornell");
  ASSERT_TRUE(cornell.ok());
  MatrixRadiosityOptions o;
  o.elements = 1000;
  Expected<MatrixRadiosity> mr = buildMatrixRadiosity(*cornell, o);
  ASSERT_TRUE(mr.ok());
  SolveOptions so;
  so.tolerance = 1e-6;
  so.solver = MatrixSolver::kJacobi;
  const SolveStats jacobi = mr->solve(so);
  mr->radiosity.assign(mr->size(), glm::vec3(0.0f));
  so.solver = MatrixSolver::kGaussSeidel;
  const SolveStats gs = mr->solve(so);
  const int kj = iterationsTo(jacobi, 1e-6), kg = iterationsTo(gs, 1e-6);
  ASSERT_GT(kj, 0);
  ASSERT_GT(kg, 0);
  const double ratio = double(kg) / double(kj);
  RecordProperty("jacobi_iterations", kj);
  RecordProperty("gauss_seidel_iterations", kg);
  EXPECT_GE(ratio, 0.4) << kg << " vs " << kj;
  EXPECT_LE(ratio, 0.7) << kg << " vs " << kj;
}

}  // namespace
}  // namespace penumbra
