// The GPU back end of the Ray Engine against the CPU back end, on llvmpipe in CI.
#include "penumbra/raytrace/ray_engine_gl.h"

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
#include <limits>

namespace penumbra {
namespace {

struct Flat {
  std::vector<glm::vec3> positions;
  std::vector<glm::uvec3> triangles;
};

Flat flatten(const Scene& s) {
  Flat f;
  for (const Mesh& m : s.meshes) {
    const uint32_t base = uint32_t(f.positions.size());
    f.positions.insert(f.positions.end(), m.positions.begin(), m.positions.end());
    for (const glm::uvec3& t : m.triangles) f.triangles.push_back(t + glm::uvec3(base));
  }
  return f;
}

glm::vec3 randomDirection(Rng& rng) {
  const float z = 1.0f - 2.0f * rng.uniform();
  const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
  const float phi = 6.2831853f * rng.uniform();
  return glm::vec3(r * std::cos(phi), r * std::sin(phi), z);
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

void expectSameAsCpu(const std::string& what, const Scene& scene) {
  const Flat f = flatten(scene);
  const RayEngine cpu = RayEngine::build(f.positions, f.triangles);
  Expected<GlRayEngine> gpu = GlRayEngine::build(f.positions, f.triangles);
  ASSERT_TRUE(gpu.ok()) << gpu.error().describe();
  const RayBatch rays = testRays(scene, cpu.bounds(), 20000);
  HitBatch a, b;
  cpu.intersect(rays, a);
  ASSERT_TRUE(gpu->intersect(rays, b).ok());
  std::vector<uint8_t> occ_cpu, occ_gpu;
  cpu.occluded(rays, occ_cpu);
  ASSERT_TRUE(gpu->occluded(rays, occ_gpu).ok());
  size_t hits = 0, ties = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    ASSERT_EQ(occ_cpu[i], occ_gpu[i]) << what << " ray " << i;
    ASSERT_EQ(a.triangle[i] >= 0, b.triangle[i] >= 0) << what << " ray " << i;
    if (a.triangle[i] < 0) continue;
    ++hits;
    ASSERT_NEAR(b.t[i], a.t[i], 1e-5f * a.t[i]) << what << " ray " << i;
    if (a.triangle[i] != b.triangle[i]) {
      // A true tie: the GPU's triangle is hit at the same distance.
      const Ray r = rays.get(i);
      const glm::uvec3 t = f.triangles[size_t(b.triangle[i])];
      float tt, u, v;
      ASSERT_TRUE(intersectTriangle(makeWatertightRay(r.origin, r.dir), f.positions[t.x],
                                    f.positions[t.y], f.positions[t.z], r.tmin, r.tmax, tt, u, v) &&
                  std::fabs(tt - a.t[i]) <= 1e-5f * a.t[i])
          << what << " ray " << i;
      ++ties;
    }
  }
  EXPECT_GT(hits, rays.size() / 8) << what;
  EXPECT_LT(ties, rays.size() / 1000 + 5) << what;
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
