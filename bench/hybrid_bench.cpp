// The tuning tables of the Ray Engine paper (Carr et al. 2002, Tables 4 and 5) for the CPU/GPU
// split (`--device hybrid`): the range of triangles T a GPU cell may hold, and the rays R sent
// per GPU pass. On this project's machines the only GPU is Mesa llvmpipe, a software
// rasteriser: these runs show how the work divides between the devices and that the split
// works, not GPU speed. Their rays/s are llvmpipe's and must not be read as GPU timings.
#include "penumbra/gpu/context.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/raytrace/camera_rays.h"
#include "penumbra/raytrace/hybrid.h"
#include "penumbra/raytrace/ray_engine.h"

#include <benchmark/benchmark.h>

#include <cstdio>
#include <memory>

namespace {

using namespace penumbra;

struct Workload {
  std::unique_ptr<GlContext> context;
  Mesh mesh;
  RayBatch rays;
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
  Expected<HybridRayEngine> engine =
      HybridRayEngine::build(w->mesh.positions, w->mesh.triangles, options);
  if (!engine) {
    state.SkipWithError(engine.error().describe().c_str());
    return;
  }
  HitBatch hits;
  HybridStats stats;
  for (auto _ : state) {
    if (!engine->intersect(w->rays, hits, &stats).ok()) state.SkipWithError("trace failed");
  }
  const double pairs = double(stats.gpu_ray_cells + stats.forced_ray_cells);
  state.counters["gpu_cells"] = double(stats.gpu_cells);
  state.counters["gpu_share"] = pairs > 0 ? double(stats.gpu_ray_cells) / pairs : 0.0;
  state.counters["gpu_batches"] = double(stats.gpu_batches);
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(w->rays.size()));
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

// Table 4: the triangle range T of a GPU cell, R = 64 rays per pass (as in the paper).
BENCHMARK(hybrid)
    ->ArgNames({"t_min", "t_max", "r"})
    ->Args({16, 64, 64})
    ->Args({64, 256, 64})
    ->Args({256, 1024, 64})
    ->Args({1024, 4096, 64})
    // Table 5: rays per pass R, T in 64..1024.
    ->Args({64, 1024, 16})
    ->Args({64, 1024, 64})
    ->Args({64, 1024, 256})
    ->Args({64, 1024, 1024})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1);
BENCHMARK(cpuOnly)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(0.5);

}  // namespace

BENCHMARK_MAIN();
