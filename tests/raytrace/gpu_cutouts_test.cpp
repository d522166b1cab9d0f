// Cut-outs on the GPU (raytrace/gpu_cutouts.h) against the CPU, on llvmpipe in CI: the GL Ray
// Engine stops where the CPU's hit filter stops, ray for ray, for masked, partly covering and
// transformed, nearest-sampled lattices; GPU progressive and stochastic radiosity's depth maps
// let an emitter's light through a lattice's openings as the CPU's shadow rays do (half the
// light for a half-open lattice).
#include "penumbra/raytrace/gpu_cutouts.h"

#include "penumbra/core/rng.h"
#include "penumbra/radiosity/progressive.h"
#include "penumbra/radiosity/progressive_gl.h"
#include "penumbra/radiosity/stochastic.h"
#include "penumbra/radiosity/stochastic_gl.h"
#include "penumbra/raytrace/cutout_filter.h"
#include "penumbra/raytrace/ray_engine.h"
#include "penumbra/raytrace/ray_engine_gl.h"
#include "support/test_util.h"
#include "support/textured_scenes.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace penumbra {
namespace {

// Rays from above the lattice of floorUnderOccluder down through it and around it.
RayBatch raysThroughTheLattice(int n) {
  RayBatch rays;
  rays.resize(size_t(n));
  Rng rng(5, 1);
  for (int i = 0; i < n; ++i) {
    Ray r;
    r.origin = glm::vec3(3.0f * rng.uniform() - 1.5f, 2.5f, 3.0f * rng.uniform() - 1.5f);
    const glm::vec3 target(2.4f * rng.uniform() - 1.2f, 0.0f, 2.4f * rng.uniform() - 1.2f);
    r.dir = glm::normalize(target - r.origin);
    rays.set(size_t(i), r);
  }
  return rays;
}

// CPU with its hit filter and GPU with its cut-out test on the same rays: the fraction of rays
// whose answers differ (a hit exactly on a texel boundary can round either way), and the share
// of the rays meeting the lattice's plane inside it that reach the floor.
void expectSameStops(const std::string& what, const Material& lattice, double open_share) {
  const Scene s = test::floorUnderOccluder(lattice, 1.0f);
  const FlatTriangles f = flattenScene(s);
  auto textures = std::make_shared<const SurfaceTextures>(s);
  ASSERT_TRUE(textures->hasCutouts());
  RayEngine cpu = RayEngine::build(f.positions, f.triangles);
  cpu.setHitFilter(cutoutFilter(textures));
  Expected<GlRayEngine> gpu = GlRayEngine::build(f.positions, f.triangles, {}, textures.get());
  ASSERT_TRUE(gpu.ok()) << gpu.error().describe();
  const RayBatch rays = raysThroughTheLattice(40000);
  HitBatch a, b;
  cpu.intersect(rays, a);
  ASSERT_TRUE(gpu->intersect(rays, b).ok());
  std::vector<uint8_t> occ_cpu, occ_gpu;
  cpu.occluded(rays, occ_cpu);
  ASSERT_TRUE(gpu->occluded(rays, occ_gpu).ok());
  size_t differ = 0, inside = 0, through = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    differ += a.triangle[i] != b.triangle[i];
    const Ray r = rays.get(i);
    const glm::vec3 p = r.origin + r.dir * ((1.0f - r.origin.y) / r.dir.y);
    if (std::abs(p.x) < 1.0f && std::abs(p.z) < 1.0f) {
      ++inside;
      through += b.triangle[i] >= 0 && b.triangle[i] < 2;  // the floor's two triangles
    }
  }
  size_t occ_differ = 0;
  for (size_t i = 0; i < rays.size(); ++i) occ_differ += occ_cpu[i] != occ_gpu[i];
  const double share = double(through) / double(inside);
  std::printf(
      "%s: %zu of %zu closest hits and %zu occlusion answers differ; %.4f of the rays "
      "through the lattice reach the floor (expected %.4f)\n",
      what.c_str(), differ, rays.size(), occ_differ, share, open_share);
  EXPECT_LE(differ, rays.size() / 2000) << what;
  EXPECT_LE(occ_differ, rays.size() / 2000) << what;
  EXPECT_NEAR(share, open_share, 0.02) << what;
}

TEST(GpuCutouts, RayEngineStopsWhereTheCpuFilterStops) {
  PENUMBRA_GL_OR_SKIP();
  expectSameStops("MASK", test::maskedLattice(AlphaMode::kMask), 0.5);
  // BLEND: the covered half stops with probability 0.5 (the same hash of the ray on both).
  Material blend = test::maskedLattice(AlphaMode::kBlend);
  blend.alpha = 0.5f;
  expectSameStops("BLEND at alpha 0.5", blend, 0.75);
  // A nearest sampler, mirrored wrap and a rotated, scaled UV transform: the CPU's lookup,
  // reproduced in the shader. Half the lattice stays open whatever the transform does to the
  // (many) cells.
  Material moved = test::maskedLattice(AlphaMode::kMask);
  moved.reflectance_texture->sampler.nearest = true;
  moved.reflectance_texture->sampler.wrap_s = TextureWrap::kMirroredRepeat;
  moved.reflectance_texture->sampler.wrap_t = TextureWrap::kClampToEdge;
  moved.reflectance_texture->setTransform(glm::vec2(0.1f, 0.2f), 0.3f, glm::vec2(3.0f, 2.0f));
  expectSameStops("MASK, nearest, mirrored, transformed", moved, 0.5);
}

// Every ray from the emitter to the floor under the lattice crosses the lattice: an open one
// lets all of it through, a half-masked one half (its cells are small against the penumbrae).
TEST(GpuCutouts, ProgressiveAndStochasticDepthMapsLetHalfTheLightThrough) {
  PENUMBRA_GL_OR_SKIP();
  const Material half = test::maskedLattice(AlphaMode::kMask);
  Material open = half;
  open.alpha = 0.0f;
  double progressive[2][2] = {};  // [open, half][cpu, gpu]
  double stochastic[2][2] = {};   // [open, half][cpu, gpu]
  for (int k = 0; k < 2; ++k) {
    const Scene s = test::emitterOverLattice(k == 0 ? open : half);
    ProgressiveOptions o;
    o.shooter_top_points = 0;
    o.shading_normals = false;
    o.atlas.texel_density = 8.0;
    o.convergence = 1e-3;
    o.max_iterations = 400;
    Expected<ProgressiveRadiosity> cpu = ProgressiveRadiosity::build(s, o);
    ASSERT_TRUE(cpu.ok()) << cpu.error().describe();
    Expected<GlProgressive> gpu = GlProgressive::create(*cpu);
    ASSERT_TRUE(gpu.ok()) << gpu.error().describe();
    ASSERT_TRUE(gpu->solve().ok());
    Expected<ProgressiveState> st = gpu->download();
    ASSERT_TRUE(st.ok());
    cpu->solve();
    std::vector<glm::dvec3> b_cpu(cpu->elementCount());
    for (size_t e = 0; e < b_cpu.size(); ++e) b_cpu[e] = cpu->radiosity(e);
    progressive[k][0] = test::floorMeanUnder(cpu->atlas(), b_cpu);
    progressive[k][1] = test::floorMeanUnder(cpu->atlas(), st->radiosity);

    StochasticOptions so;
    so.atlas.texel_density = 8.0;
    so.iterations = 250;
    so.shading_normals = false;
    Expected<StochasticRadiosity> sr = StochasticRadiosity::build(s, so);
    ASSERT_TRUE(sr.ok()) << sr.error().describe();
    Expected<GlStochastic> g = GlStochastic::create(*sr);
    ASSERT_TRUE(g.ok()) << g.error().describe();
    ASSERT_TRUE(g->solve().ok());
    Expected<std::vector<glm::dvec3>> b = g->radiosity();
    ASSERT_TRUE(b.ok());
    stochastic[k][1] = test::floorMeanUnder(sr->atlas(), *b);
    sr->solve();
    stochastic[k][0] = test::floorMeanUnder(sr->atlas(), sr->radiosity());
  }
  std::printf(
      "floor under the lattice, open / half-masked: progressive CPU %.4f / %.4f, GPU "
      "%.4f / %.4f; stochastic CPU %.4f / %.4f, GPU %.4f / %.4f\n",
      progressive[0][0], progressive[1][0], progressive[0][1], progressive[1][1], stochastic[0][0],
      stochastic[1][0], stochastic[0][1], stochastic[1][1]);
  for (int k = 0; k < 2; ++k) {
    EXPECT_NEAR(progressive[k][1], progressive[k][0], 0.02 * progressive[k][0]) << k;
    EXPECT_NEAR(stochastic[k][1], stochastic[k][0], 0.04 * stochastic[k][0]) << k;
  }
  for (int d = 0; d < 2; ++d) {
    EXPECT_NEAR(progressive[1][d] / progressive[0][d], 0.5, 0.02) << d;
    EXPECT_NEAR(stochastic[1][d] / stochastic[0][d], 0.5, 0.04) << d;
  }
}

}  // namespace
}  // namespace penumbra
