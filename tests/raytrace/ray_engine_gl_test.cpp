// The GPU back end of the Ray Engine against the CPU back end, on llvmpipe in CI.
#include "penumbra/raytrace/ray_engine_gl.h"

#include "penumbra/raytrace/hybrid.h"
#include "penumbra/raytrace/path_tracer.h"
#include "penumbra/raytrace/ray_queries.h"

#include "penumbra/core/rng.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/kernels/ray_triangle.h"
#include "penumbra/kernels/sampling.h"
#include "penumbra/raytrace/camera_rays.h"
#include "penumbra/raytrace/ray_engine.h"
#include "penumbra/scene/builtin.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

namespace penumbra {
namespace {

using test::expectInternalError;
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
// and short caches forced to the CPU, whatever the capacity of the cells' ray caches (sec. 5.3:
// 16 = R_min sends rays in arrival order; 0 is the default, 4 R_min).
TEST(HybridRayEngine, AgreesWithCpuAndUsesBothDevices) {
  PENUMBRA_GL_OR_SKIP();
  for (const std::string file : {"bunny.ply", "teapot.ply"}) {
    Expected<Scene> s = loadScene(test::dataPath(file));
    ASSERT_TRUE(s.ok());
    const Flat f = flatten(*s);
    const RayEngine cpu = RayEngine::build(f.positions, f.triangles);
    const RayBatch rays = testRays(*s, cpu.bounds(), 4000);
    HitBatch a;
    cpu.intersect(rays, a);
    for (const uint32_t cache_rays : {16u, 0u, 100u, 1024u}) {
      const std::string what = file + " cache_rays " + std::to_string(cache_rays);
      HybridOptions options;
      options.t_min = 32;
      options.t_max = 256;
      options.r_min = 16;  // 4x4 tiles: the random rays spread over many cells
      options.cache_rays = cache_rays;
      Expected<HybridRayEngine> hybrid = HybridRayEngine::build(f.positions, f.triangles, options);
      ASSERT_TRUE(hybrid.ok()) << hybrid.error().describe();
      EXPECT_GT(hybrid->cellCount(), 4u) << what;
      EXPECT_EQ(hybrid->options().cache_rays, cache_rays ? cache_rays : 64u);
      HitBatch b;
      HybridStats stats;
      ASSERT_TRUE(hybrid->intersect(rays, b, &stats).ok());
      expectSameHits(what, f, rays, a, b);
      EXPECT_GT(stats.gpu_batches, 0u) << what;
      EXPECT_EQ(stats.gpu_ray_cells, stats.gpu_batches * 16) << what;
      EXPECT_GT(stats.forced_ray_cells, 0u) << what;
      EXPECT_GE(stats.gpu_triangles, stats.gpu_batches * 32) << what;
      EXPECT_LE(stats.gpu_triangles, stats.gpu_batches * 256) << what;
      EXPECT_GT(stats.gpu_triangles_culled, 0u) << what;
      EXPECT_LT(stats.gpu_triangles_culled, stats.gpu_triangles) << what;
      // The same answers again: nothing is kept between calls.
      HitBatch c;
      ASSERT_TRUE(hybrid->intersect(rays, c).ok());
      EXPECT_EQ(b.triangle, c.triangle) << what;
      EXPECT_EQ(b.t, c.t) << what;
    }
  }
}

// Diffuse bounces at the bunny, the incoherent rays of a path tracer: from uniformly chosen
// points of uniformly chosen triangles, cosine-distributed about the normal on either side, in
// random order.
RayBatch diffuseRays(const Flat& f, const Bounds3& box, size_t n) {
  RayBatch rays;
  rays.resize(n);
  Rng rng(21, 5);
  for (size_t i = 0; i < n; ++i) {
    const glm::uvec3 t = f.triangles[rng.uniformInt(uint32_t(f.triangles.size()))];
    const glm::vec3 p0 = f.positions[t.x], p1 = f.positions[t.y], p2 = f.positions[t.z];
    const glm::vec3 normal = glm::cross(p1 - p0, p2 - p0);
    const float side = rng.uniform() < 0.5f ? 1.0f : -1.0f;
    const glm::vec2 b = sampleTriangleBarycentrics(rng.uniform(), rng.uniform());
    const glm::vec3 local = sampleCosineHemisphere(rng.uniform(), rng.uniform());
    Ray r;
    r.origin = (1.0f - b.x - b.y) * p0 + b.x * p1 + b.y * p2;
    r.dir = glm::length(normal) > 0.0f
                ? Frame::fromNormal(side * glm::normalize(normal)).toWorld(local)
                : randomDirection(rng);
    r.tmin = 1e-4f * glm::length(box.extent());
    rays.set(i, r);
  }
  return rays;
}

// The ray cache's point (sec. 5.3): buckets drawn by the 5-D ray tree from a cache of 16 R_min
// rays are coherent enough for the vertex stage to cull a clearly larger share of each cell's
// triangles than buckets of the first R_min rays to arrive (cache_rays = R_min), on incoherent
// rays; both give the CPU's answers. GPU cells of 1024-4096 triangles (the paper's Table 4).
// Measured: 1.3% culled in arrival order, 20.3% through the cache (23.4% with a cache that holds
// every cell's rays until the end).
TEST(HybridRayEngine, CoherentBucketsCullMoreTrianglesThanArrivalOrder) {
  PENUMBRA_GL_OR_SKIP();
  Expected<Scene> s = loadScene(test::dataPath("bunny.ply"));
  ASSERT_TRUE(s.ok());
  const Flat f = flatten(*s);
  const RayEngine cpu = RayEngine::build(f.positions, f.triangles);
  const RayBatch rays = diffuseRays(f, cpu.bounds(), 5000);
  HitBatch a;
  cpu.intersect(rays, a);
  double fraction[2];
  size_t passes[2];
  for (int k = 0; k < 2; ++k) {
    HybridOptions options;
    options.t_min = 1024;
    options.t_max = 4096;
    options.r_min = 16;
    options.cache_rays = k == 0 ? 16 : 256;
    Expected<HybridRayEngine> hybrid = HybridRayEngine::build(f.positions, f.triangles, options);
    ASSERT_TRUE(hybrid.ok()) << hybrid.error().describe();
    HitBatch b;
    HybridStats stats;
    ASSERT_TRUE(hybrid->intersect(rays, b, &stats).ok());
    expectSameHits("cache_rays " + std::to_string(options.cache_rays), f, rays, a, b);
    ASSERT_GT(stats.gpu_triangles, 0u);
    fraction[k] = double(stats.gpu_triangles_culled) / double(stats.gpu_triangles);
    passes[k] = stats.gpu_batches;
    std::printf("cache_rays %u: %zu GPU passes, %.1f%% of %zu triangles culled\n",
                options.cache_rays, stats.gpu_batches, 100.0 * fraction[k], stats.gpu_triangles);
  }
  // As many passes either way (each cell sends all its rays but a remainder short of R_min),
  // so the shares compare like with like.
  EXPECT_EQ(passes[0], passes[1]);
  EXPECT_GT(fraction[1], fraction[0] + 0.1);
  EXPECT_GT(fraction[1], 5.0 * fraction[0]);
}

TEST(HybridRayEngineContract, ACacheSmallerThanABucketIsAContractViolation) {
  const std::vector<glm::vec3> p = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  const std::vector<glm::uvec3> t = {{0, 1, 2}};
  HybridOptions options;
  options.r_min = 64;
  options.cache_rays = 63;
  expectInternalError([&] { (void)HybridRayEngine::build(p, t, options); }, "cache_rays 63");
}

// The vertex stage really culls (sec. 5.3): of four triangles, three lie behind a coherent
// bucket of rays, and only the fourth's quad survives clipping (counted by a pipeline
// statistics query where the driver has one); the answers are those of all four.
TEST(GlRasterKernel, VertexStageCullsTrianglesOutOfReach) {
  PENUMBRA_GL_OR_SKIP();
  std::vector<glm::vec3> p;
  std::vector<glm::uvec3> t;
  for (const float z : {-1.0f, -2.0f, -3.0f, 2.0f}) {  // the rays start at z = 0, going +z
    const uint32_t k = uint32_t(p.size());
    p.insert(p.end(), {{-1, -1, z}, {1, -1, z}, {0, 1, z}});
    t.push_back({k, k + 1, k + 2});
  }
  Expected<GlRasterKernel> kernel = GlRasterKernel::create(p, t, 4);
  ASSERT_TRUE(kernel.ok()) << kernel.error().describe();
  RayBatch rays;
  rays.resize(16);
  for (size_t i = 0; i < 16; ++i) {
    rays.set(i, Ray{{0.01f * float(i % 4), 0.01f * float(i / 4), 0.0f}, 0.0f, {0, 0, 1}, 10.0f});
  }
  std::vector<uint32_t> indices(16);
  for (uint32_t i = 0; i < 16; ++i) indices[i] = i;
  const bool query = epoxy_has_gl_extension("GL_ARB_pipeline_statistics_query");
  GLuint q = 0;
  if (query) {
    glGenQueries(1, &q);
    glBeginQuery(GL_CLIPPING_OUTPUT_PRIMITIVES_ARB, q);
  }
  Expected<GlRasterKernel::Job> job = kernel->submit(rays, indices, 0, 4);
  ASSERT_TRUE(job.ok()) << job.error().describe();
  if (query) glEndQuery(GL_CLIPPING_OUTPUT_PRIMITIVES_ARB);
  EXPECT_EQ(job->bound.mode, BucketCullMode::kBeam);
  EXPECT_EQ(kernel->culledTriangles(job->bound, 0, 4), 3u);
  std::vector<Hit> out(16);
  kernel->collect(*job, out.data());
  for (const Hit& h : out) {
    EXPECT_EQ(h.triangle, 3);
    EXPECT_FLOAT_EQ(h.t, 2.0f);
  }
  if (!query) GTEST_SKIP() << "no GL_ARB_pipeline_statistics_query: answers checked only";
  GLuint64 primitives = 0;
  glGetQueryObjectui64v(q, GL_QUERY_RESULT, &primitives);
  glDeleteQueries(1, &q);
  EXPECT_EQ(primitives, 2u);  // one quad: two triangles of the strip
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
