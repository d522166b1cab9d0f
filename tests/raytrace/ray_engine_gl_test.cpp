// The GPU back end of the Ray Engine against the CPU back end, on llvmpipe in CI.
#include "penumbra/raytrace/ray_engine_gl.h"

#include "penumbra/raytrace/hybrid.h"
#include "penumbra/raytrace/path_tracer.h"
#include "penumbra/raytrace/ray_queries.h"

#include "penumbra/core/rng.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/kernels/ray_triangle.h"
#include "penumbra/raytrace/camera_rays.h"
#include "penumbra/raytrace/ray_engine.h"
#include "penumbra/scene/builtin.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <cmath>
#include <cstdio>
#include <limits>

namespace penumbra {
namespace {

using test::randomDirection;
using test::randomInBox;

using Flat = FlatTriangles;
Flat flatten(const Scene& s) {
  return flattenScene(s);
}

// Camera rays plus random rays from around and inside the model's box.
RayBatch testRays(const Scene& s, const Bounds3& box, int n_random) {
  RayBatch rays;
  const Camera cam = s.camera ? *s.camera : defaultCamera(s);
  const CameraRays camera(cam, 64, 64);
  rays.resize(64 * 64 + size_t(n_random));
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) rays.set(size_t(y * 64 + x), camera.ray(x + 0.5f, y + 0.5f));
  }
  Rng rng(11, 3);
  for (int i = 0; i < n_random; ++i) {
    Ray r;
    r.origin = box.lo + box.extent() * glm::vec3(rng.uniform(), rng.uniform(), rng.uniform());
    if (i % 2) r.origin = box.center() + 1.5f * glm::length(box.extent()) * randomDirection(rng);
    r.dir = randomDirection(rng);
    if (i % 5 == 0) r.tmax = 0.3f * glm::length(box.extent());
    rays.set(size_t(64 * 64 + i), r);
  }
  return rays;
}

// Same triangle as the CPU except at true ties (checked by intersecting the other triangle),
// t within 1e-5 relative. For hits a hair from the origin, t is computed from differences of
// coordinates and carries an absolute rounding error of a few ulps of the scene's size; the
// tolerance never goes below 1e-6 of the scene's extent (in units of the direction's length).
void expectSameHits(const std::string& what, const Flat& f, const RayBatch& rays, const HitBatch& a,
                    const HitBatch& b) {
  Bounds3 box;
  for (const glm::vec3& p : f.positions) box.extend(p);
  const float extent = glm::length(box.extent());
  size_t hits = 0, ties = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    ASSERT_EQ(a.triangle[i] >= 0, b.triangle[i] >= 0) << what << " ray " << i;
    if (a.triangle[i] < 0) continue;
    ++hits;
    const float floor = 1e-6f * extent / glm::length(rays.get(i).dir);
    ASSERT_NEAR(b.t[i], a.t[i], std::max(1e-5f * a.t[i], floor)) << what << " ray " << i;
    if (a.triangle[i] != b.triangle[i]) {
      // A true tie: the GPU's triangle is hit at the same distance.
      const Ray r = rays.get(i);
      const glm::uvec3 t = f.triangles[size_t(b.triangle[i])];
      float tt, u, v;
      ASSERT_TRUE(intersectTriangle(makeWatertightRay(r.origin, r.dir), f.positions[t.x],
                                    f.positions[t.y], f.positions[t.z], r.tmin, r.tmax, tt, u, v) &&
                  std::fabs(tt - a.t[i]) <= std::max(1e-5f * a.t[i], floor))
          << what << " ray " << i;
      ++ties;
    }
  }
  EXPECT_GT(hits, rays.size() / 8) << what;
  EXPECT_LT(ties, rays.size() / 1000 + 5) << what;
}

void expectSameAsCpu(const std::string& what, const Scene& scene) {
  const Flat f = flatten(scene);
  const RayEngine cpu = RayEngine::build(f.positions, f.triangles);
  Expected<GlRayEngine> gpu = GlRayEngine::build(f.positions, f.triangles);
  ASSERT_TRUE(gpu.ok()) << gpu.error().describe();
  const RayBatch rays = testRays(scene, cpu.bounds(), 20000);
  HitBatch a, b;
  cpu.intersect(rays, a);
  ASSERT_TRUE(gpu->intersect(rays, b).ok());
  expectSameHits(what, f, rays, a, b);
  std::vector<uint8_t> occ_cpu, occ_gpu;
  cpu.occluded(rays, occ_cpu);
  ASSERT_TRUE(gpu->occluded(rays, occ_gpu).ok());
  EXPECT_EQ(occ_cpu, occ_gpu) << what;
}

TEST(GlRayEngine, AgreesWithCpuOnBunnyTeapotAndCornell) {
  PENUMBRA_GL_OR_SKIP();
  for (const std::string file : {"bunny.ply", "teapot.ply"}) {
    Expected<Scene> s = loadScene(test::dataPath(file));
    ASSERT_TRUE(s.ok()) << s.error().describe();
    expectSameAsCpu(file, *s);
  }
  Expected<Scene> cornell = builtinScene("cornell");
  ASSERT_TRUE(cornell.ok());
  expectSameAsCpu("cornell", *cornell);
}

// The paper's kernel (rays per pixel, triangles as quads, eq. 1-8, depth test as t-buffer).
void expectRasterKernelSameAsCpu(const std::string& what, const Scene& scene, int random_rays,
                                 int tile) {
  const Flat f = flatten(scene);
  const RayEngine cpu = RayEngine::build(f.positions, f.triangles);
  Expected<GlRasterKernel> kernel = GlRasterKernel::create(f.positions, f.triangles, tile);
  ASSERT_TRUE(kernel.ok()) << kernel.error().describe();
  RayBatch rays = testRays(scene, cpu.bounds(), random_rays);
  HitBatch a, b;
  cpu.intersect(rays, a);
  ASSERT_TRUE(kernel->intersect(rays, b).ok());
  expectSameHits(what, f, rays, a, b);
  // Barycentrics from eq. 6-8 reproduce the hit point.
  for (size_t i = 0; i < rays.size(); ++i) {
    if (b.triangle[i] < 0) continue;
    const glm::uvec3 t = f.triangles[size_t(b.triangle[i])];
    const glm::vec3 p = (1.0f - b.u[i] - b.v[i]) * f.positions[t.x] + b.u[i] * f.positions[t.y] +
                        b.v[i] * f.positions[t.z];
    const Ray r = rays.get(i);
    ASSERT_LT(glm::length(p - (r.origin + b.t[i] * r.dir)),
              1e-4f * glm::length(cpu.bounds().extent()))
        << what << " ray " << i;
  }
}

TEST(GlRasterKernel, AgreesWithCpuOnBunnyTeapotAndCornell) {
  PENUMBRA_GL_OR_SKIP();
  Expected<Scene> cornell = builtinScene("cornell");
  ASSERT_TRUE(cornell.ok());
  expectRasterKernelSameAsCpu("cornell", *cornell, 6000, 64);
  Expected<Scene> teapot = loadScene(test::dataPath("teapot.ply"));
  ASSERT_TRUE(teapot.ok());
  expectRasterKernelSameAsCpu("teapot", *teapot, 4000, 64);
  Expected<Scene> bunny = loadScene(test::dataPath("bunny.ply"));
  ASSERT_TRUE(bunny.ok());
  expectRasterKernelSameAsCpu("bunny", *bunny, 0, 16);  // 4096 camera rays, 16x16 per pass
}

TEST(GlRasterKernel, TriangleSubsetsAndTies) {
  PENUMBRA_GL_OR_SKIP();
  // Two coincident triangles (ids 0 and 1) and one behind them (id 2).
  const std::vector<glm::vec3> p = {{0, 0, 0},  {1, 0, 0},  {0, 1, 0},
                                    {0, 0, -1}, {1, 0, -1}, {0, 1, -1}};
  const std::vector<glm::uvec3> t = {{0, 1, 2}, {0, 1, 2}, {3, 4, 5}};
  Expected<GlRasterKernel> kernel = GlRasterKernel::create(p, t, 4);
  ASSERT_TRUE(kernel.ok()) << kernel.error().describe();
  RayBatch rays;
  rays.resize(1);
  rays.set(0, Ray{{0.2f, 0.3f, 1.0f}, 0.0f, {0, 0, -1}, 10.0f});
  HitBatch hits;
  ASSERT_TRUE(kernel->intersect(rays, hits).ok());
  EXPECT_EQ(hits.triangle[0], 0);  // exact tie: the lower id
  EXPECT_FLOAT_EQ(hits.t[0], 1.0f);
  EXPECT_FLOAT_EQ(hits.u[0], 0.2f);
  EXPECT_FLOAT_EQ(hits.v[0], 0.3f);
  ASSERT_TRUE(kernel->intersect(rays, hits, 1, 2).ok());
  EXPECT_EQ(hits.triangle[0], 1);
  ASSERT_TRUE(kernel->intersect(rays, hits, 2, 1).ok());
  EXPECT_EQ(hits.triangle[0], 2);
  EXPECT_FLOAT_EQ(hits.t[0], 2.0f);
  rays.set(0, Ray{{0.2f, 0.3f, 1.0f}, 0.0f, {0, 0, -1}, 1.5f});  // tmax before the far one
  ASSERT_TRUE(kernel->intersect(rays, hits, 2, 1).ok());
  EXPECT_EQ(hits.triangle[0], -1);
}

// The CPU/GPU split (sec. 6.2): the CPU back end's answers, with work actually sent to the GPU
// and short caches forced to the CPU.
TEST(HybridRayEngine, AgreesWithCpuAndUsesBothDevices) {
  PENUMBRA_GL_OR_SKIP();
  for (const std::string file : {"bunny.ply", "teapot.ply"}) {
    Expected<Scene> s = loadScene(test::dataPath(file));
    ASSERT_TRUE(s.ok());
    const Flat f = flatten(*s);
    HybridOptions options;
    options.t_min = 32;
    options.t_max = 256;
    options.r_min = 16;  // 4x4 tiles: the random rays spread over many cells
    Expected<HybridRayEngine> hybrid = HybridRayEngine::build(f.positions, f.triangles, options);
    ASSERT_TRUE(hybrid.ok()) << hybrid.error().describe();
    EXPECT_GT(hybrid->cellCount(), 4u) << file;
    const RayEngine cpu = RayEngine::build(f.positions, f.triangles);
    const RayBatch rays = testRays(*s, cpu.bounds(), 4000);
    HitBatch a, b;
    cpu.intersect(rays, a);
    HybridStats stats;
    ASSERT_TRUE(hybrid->intersect(rays, b, &stats).ok());
    expectSameHits(file, f, rays, a, b);
    EXPECT_GT(stats.gpu_batches, 0u) << file;
    EXPECT_GT(stats.gpu_ray_cells, 0u) << file;
    EXPECT_GT(stats.forced_ray_cells, 0u) << file;
  }
}

TEST(GlRayEngine, HonoursTminTmaxAndEmptyBatches) {
  PENUMBRA_GL_OR_SKIP();
  const std::vector<glm::vec3> p = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  const std::vector<glm::uvec3> t = {{0, 1, 2}};
  Expected<GlRayEngine> gpu = GlRayEngine::build(p, t);
  ASSERT_TRUE(gpu.ok()) << gpu.error().describe();
  RayBatch rays;
  rays.resize(3);
  rays.set(0, Ray{{0.25f, 0.5f, 2.0f}, 0.0f, {0, 0, -1}, 10.0f});
  rays.set(1, Ray{{0.25f, 0.5f, 2.0f}, 0.0f, {0, 0, -1}, 1.9f});
  rays.set(2, Ray{{0.25f, 0.5f, 2.0f}, 2.1f, {0, 0, -1}, 10.0f});
  HitBatch hits;
  ASSERT_TRUE(gpu->intersect(rays, hits).ok());
  EXPECT_EQ(hits.triangle[0], 0);
  EXPECT_FLOAT_EQ(hits.t[0], 2.0f);
  EXPECT_FLOAT_EQ(hits.u[0], 0.25f);
  EXPECT_FLOAT_EQ(hits.v[0], 0.5f);
  EXPECT_EQ(hits.triangle[1], -1);
  EXPECT_EQ(hits.triangle[2], -1);
  RayBatch none;
  ASSERT_TRUE(gpu->intersect(none, hits).ok());
  EXPECT_EQ(hits.size(), 0u);
}

}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {

// The wavefront path tracer gives render()'s image bit for bit on the CPU, and the same image
// up to the GPU kernel's last-bit differences in t on the GPU and through the CPU/GPU split.
TEST(PathTracerWavefront, SameImageOnEveryBackEnd) {
  Expected<Scene> s = builtinScene("cornell");
  ASSERT_TRUE(s.ok());
  const PathTracer pt(*s);
  PathTracerSettings settings;
  settings.width = 24;
  settings.height = 20;
  settings.spp = 6;
  settings.seed = 5;
  const Image reference = pt.render(*s->camera, settings);
  CpuRayQueries cpu(pt.geometry().engine);
  Expected<Image> wave = pt.renderWavefront(*s->camera, settings, cpu);
  ASSERT_TRUE(wave.ok());
  for (size_t i = 0; i < reference.pixels.size(); ++i) {
    ASSERT_EQ(wave->pixels[i], reference.pixels[i]) << i;
  }

  PENUMBRA_GL_OR_SKIP();
  const SceneGeometry& g = pt.geometry();
  Expected<GlRayEngine> gl = GlRayEngine::build(g.positions, g.triangles);
  ASSERT_TRUE(gl.ok()) << gl.error().describe();
  HybridOptions split;
  split.t_min = 2;  // the Cornell box is small: make cells of a few triangles
  split.t_max = 8;
  split.r_min = 16;
  Expected<HybridRayEngine> hy = HybridRayEngine::build(g.positions, g.triangles, split);
  ASSERT_TRUE(hy.ok()) << hy.error().describe();
  GpuRayQueries gpu(*gl);
  HybridRayQueries hybrid(*hy);
  for (RayQueries* q : std::initializer_list<RayQueries*>{&gpu, &hybrid}) {
    Expected<Image> img = pt.renderWavefront(*s->camera, settings, *q);
    ASSERT_TRUE(img.ok()) << img.error().describe();
    double err = 0.0, norm = 0.0;
    size_t differing = 0;
    for (size_t i = 0; i < reference.pixels.size(); ++i) {
      const glm::vec3 d = img->pixels[i] - reference.pixels[i];
      err += double(glm::dot(d, d));
      norm += double(glm::dot(reference.pixels[i], reference.pixels[i]));
      differing += img->pixels[i] != reference.pixels[i];
    }
    // The compute kernel reproduces the CPU's t bit for bit here; the split's raster kernel
    // (eq. 1-8) differs in the last bits of t, which moves hit points by an ulp: most pixels
    // differ in their last bits (measured: relative RMS 4e-8).
    EXPECT_LT(std::sqrt(err / norm), 1e-4) << differing << " pixels differ";
  }
  EXPECT_GT(hybrid.stats().gpu_batches, 0u);
}

}  // namespace
}  // namespace penumbra
