// The tuning tables of the Ray Engine paper (Carr et al. 2002, Tables 4 and 5) for the CPU/GPU
// split (`--device hybrid`): the range of triangles T a GPU cell may hold, and the rays R sent
// per GPU pass; and a third table for the capacity of each cell's ray cache (sec. 5.3), whose
// coherent buckets let the kernel's vertex stage cull the triangles out of a bucket's reach.
// On this project's machines the only GPU is Mesa llvmpipe, a software rasteriser: these are
// correctness runs that show how the work divides between the devices and how many triangles
// are culled, not GPU speed. Their rays/s are llvmpipe's and must not be read as GPU timings.
#include "penumbra/core/rng.h"
#include "penumbra/gpu/context.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/kernels/sampling.h"
#include "penumbra/raytrace/camera_rays.h"
#include "penumbra/raytrace/hybrid.h"
#include "penumbra/raytrace/ray_engine.h"

#include <benchmark/benchmark.h>
#include <glm/geometric.hpp>

#include <cmath>
#include <cstdio>
#include <memory>

namespace {

using namespace penumbra;

struct Workload {
  std::unique_ptr<GlContext> context;
  Mesh mesh;
  RayBatch rays;     // 256x256 camera rays (coherent, in scanline order)
  RayBatch diffuse;  // one cosine-distributed bounce from each camera ray's hit (incoherent)
};

Workload* workload() {
  static Workload* w = []() -> Workload* {
    auto* wl = new Workload;
    Expected<std::unique_ptr<GlContext>> ctx = GlContext::createHeadless();
    if (!ctx) {
      std::fprintf(stderr, "hybrid_bench: %s\n", ctx.error().describe().c_str());
      return nullptr;
    }
    wl->context = std::move(*ctx);
    Expected<Scene> s = loadScene(std::string(PENUMBRA_BENCH_DATA) + "/bunny.ply");
    if (!s) return nullptr;
    wl->mesh = s->meshes[0];
    const CameraRays camera(defaultCamera(*s), 256, 256);
    wl->rays.resize(256 * 256);
    for (int y = 0; y < 256; ++y) {
      for (int x = 0; x < 256; ++x) {
        wl->rays.set(size_t(y) * 256 + size_t(x), camera.ray(float(x) + 0.5f, float(y) + 0.5f));
      }
    }
    // Diffuse bounces off the bunny, in pixel order, as a path tracer's second bounce.
    const RayEngine cpu = RayEngine::build(wl->mesh.positions, wl->mesh.triangles);
    HitBatch hits;
    cpu.intersect(wl->rays, hits);
    Rng rng(7, 7);
    for (size_t i = 0; i < wl->rays.size(); ++i) {
      if (hits.triangle[i] < 0) continue;
      const glm::uvec3 t = wl->mesh.triangles[size_t(hits.triangle[i])];
      const glm::vec3 p0 = wl->mesh.positions[t.x], p1 = wl->mesh.positions[t.y],
                      p2 = wl->mesh.positions[t.z];
      glm::vec3 n = glm::cross(p1 - p0, p2 - p0);
      const Ray in = wl->rays.get(i);
      if (!(glm::length(n) > 0.0f)) continue;
      n = glm::normalize(n);
      if (glm::dot(n, in.dir) > 0.0f) n = -n;  // the side the camera ray came from
      Ray r;
      r.origin = in.origin + hits.t[i] * in.dir;
      r.dir = Frame::fromNormal(n).toWorld(sampleCosineHemisphere(rng.uniform(), rng.uniform()));
      r.tmin = 1e-4f * glm::length(cpu.bounds().extent());
      const size_t k = wl->diffuse.size();
      wl->diffuse.resize(k + 1);
      wl->diffuse.set(k, r);
    }
    return wl;
  }();
  return w;
}

void hybrid(benchmark::State& state) {
  Workload* w = workload();
  if (!w) {
    state.SkipWithError("no OpenGL 4.5 context");
    return;
  }
  HybridOptions options;
  options.t_min = uint32_t(state.range(0));
  options.t_max = uint32_t(state.range(1));
  options.r_min = uint32_t(state.range(2));
  options.cache_rays = uint32_t(state.range(3));  // 0: the default, 4 R
  const RayBatch& rays = state.range(4) ? w->diffuse : w->rays;
  Expected<HybridRayEngine> engine =
      HybridRayEngine::build(w->mesh.positions, w->mesh.triangles, options);
  if (!engine) {
    state.SkipWithError(engine.error().describe().c_str());
    return;
  }
  HitBatch hits;
  HybridStats stats;
  for (auto _ : state) {
    if (!engine->intersect(rays, hits, &stats).ok()) state.SkipWithError("trace failed");
  }
  const double pairs = double(stats.gpu_ray_cells + stats.forced_ray_cells);
  state.counters["gpu_cells"] = double(stats.gpu_cells);
  state.counters["gpu_share"] = pairs > 0 ? double(stats.gpu_ray_cells) / pairs : 0.0;
  state.counters["gpu_batches"] = double(stats.gpu_batches);
  // The share of the triangles sent with the buckets that the vertex stage culled (sec. 5.3).
  state.counters["culled"] = stats.gpu_triangles > 0
                                 ? double(stats.gpu_triangles_culled) / double(stats.gpu_triangles)
                                 : 0.0;
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(rays.size()));
}

void cpuOnly(benchmark::State& state) {
  Workload* w = workload();
  if (!w) {
    state.SkipWithError("no OpenGL 4.5 context");
    return;
  }
  const RayEngine engine = RayEngine::build(w->mesh.positions, w->mesh.triangles);
  HitBatch hits;
  for (auto _ : state) engine.intersect(w->rays, hits);
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(w->rays.size()));
}

// Table 4: the triangle range T of a GPU cell, R = 64 rays per pass (as in the paper); camera
// rays, default cache (4 R).
BENCHMARK(hybrid)
    ->ArgNames({"t_min", "t_max", "r", "cache", "diffuse"})
    ->Args({16, 64, 64, 0, 0})
    ->Args({64, 256, 64, 0, 0})
    ->Args({256, 1024, 64, 0, 0})
    ->Args({1024, 4096, 64, 0, 0})
    // Table 5: rays per pass R, T in 64..1024.
    ->Args({64, 1024, 16, 0, 0})
    ->Args({64, 1024, 64, 0, 0})
    ->Args({64, 1024, 256, 0, 0})
    ->Args({64, 1024, 1024, 0, 0})
    // The ray cache's capacity (sec. 5.3), T in 256..1024, R = 16, on camera rays and on diffuse
    // bounces: cache = R sends buckets in arrival order.
    ->Args({256, 1024, 16, 16, 0})
    ->Args({256, 1024, 16, 64, 0})
    ->Args({256, 1024, 16, 256, 0})
    ->Args({256, 1024, 16, 4096, 0})
    ->Args({256, 1024, 16, 16, 1})
    ->Args({256, 1024, 16, 64, 1})
    ->Args({256, 1024, 16, 256, 1})
    ->Args({256, 1024, 16, 4096, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1);
BENCHMARK(cpuOnly)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(0.5);

}  // namespace

BENCHMARK_MAIN();
