// Stochastic radiosity by ray-bundle shooting (Barsi and Jakab) on the CPU: time per iteration
// against the atlas's resolution (512^2 and 1024^2, the paper's pbuffer sizes) and the scene's
// size (the furnace's 8 vertices, the Cornell box, the Cornell box with four teapots, the room
// with the 69,451-triangle bunny scan), with progressive radiosity's iteration on the same atlas
// as the peer (design doc sec. 7: ratios in the same run). An iteration of either updates every
// texel facing the shooter; the stochastic one shoots from one texel, the progressive one from a
// whole shooter's points.
//   build/bin/stochastic_bench
#include "penumbra/io/scene_io.h"
#include "penumbra/radiosity/progressive.h"
#include "penumbra/radiosity/stochastic.h"

#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>

namespace {

using namespace penumbra;

const Scene& sceneNamed(const std::string& name) {
  static std::map<std::string, Scene> scenes;
  auto it = scenes.find(name);
  if (it != scenes.end()) return it->second;
  const bool builtin = name == "cornell" || name == "furnace";
  Expected<Scene> s = loadScene(builtin ? name : std::string(PENUMBRA_BENCH_SCENES) + "/" + name);
  if (!s) {
    std::fprintf(stderr, "%s\n", s.error().describe().c_str());
    std::abort();
  }
  return scenes.emplace(name, std::move(*s)).first->second;
}

size_t vertexCount(const Scene& scene) {
  size_t n = 0;
  for (const Mesh& m : scene.meshes) n += m.positions.size();
  return n;
}

ChartAtlasOptions atlasOf(int size) {
  ChartAtlasOptions a;
  a.texel_density = 0.0;  // the largest density whose atlas fits size x size
  a.resolution = size;
  return a;
}

void stochasticIterations(benchmark::State& state, const std::string& name) {
  const Scene& scene = sceneNamed(name);
  StochasticOptions o;
  o.atlas = atlasOf(int(state.range(0)));
  Expected<StochasticRadiosity> built = StochasticRadiosity::build(scene, o);
  if (!built) {
    state.SkipWithError(built.error().describe().c_str());
    return;
  }
  StochasticRadiosity& sr = *built;
  for (int i = 0; i < sr.burnIn(); ++i) sr.step();  // a typical iterate, light everywhere
  double seconds = 0.0, rays = 0.0, iterations = 0.0;
  for (auto _ : state) {
    const StochasticIteration it = sr.step();
    seconds += it.seconds;
    rays += double(it.rays);
    iterations += 1.0;
  }
  state.counters["vertices"] = double(vertexCount(scene));
  state.counters["texels"] = double(sr.elementCount());
  state.counters["ms_per_iteration"] = 1e3 * seconds / iterations;
  state.counters["mrays_per_s"] = rays / seconds * 1e-6;
  std::printf(
      "stochastic, %s (%zu vertices), %dx%d atlas, %zu texels: %.2f ms per iteration, "
      "%.1f Mrays/s\n",
      name.c_str(), vertexCount(scene), sr.atlas().width, sr.atlas().height, sr.elementCount(),
      1e3 * seconds / iterations, rays / seconds * 1e-6);
}

void progressiveIterations(benchmark::State& state, const std::string& name) {
  const Scene& scene = sceneNamed(name);
  ProgressiveOptions o;
  o.atlas = atlasOf(int(state.range(0)));
  o.convergence = 0.0;
  Expected<ProgressiveRadiosity> built = ProgressiveRadiosity::build(scene, o);
  if (!built) {
    state.SkipWithError(built.error().describe().c_str());
    return;
  }
  ProgressiveRadiosity& pr = *built;
  double seconds = 0.0, iterations = 0.0;
  for (auto _ : state) {
    const ProgressiveIteration it = pr.step();
    seconds += it.seconds;
    iterations += 1.0;
  }
  state.counters["texels"] = double(pr.elementCount());
  state.counters["ms_per_iteration"] = 1e3 * seconds / iterations;
  std::printf("progressive, %s, %zu texels: %.2f ms per iteration\n", name.c_str(),
              pr.elementCount(), 1e3 * seconds / iterations);
}

#define PENUMBRA_SCENE_BENCH(fn, label, file) \
  BENCHMARK_CAPTURE(fn, label, file)          \
      ->Arg(512)                              \
      ->Arg(1024)                             \
      ->Iterations(40)                        \
      ->UseRealTime()                         \
      ->Unit(benchmark::kMillisecond)

PENUMBRA_SCENE_BENCH(stochasticIterations, furnace, "furnace");
PENUMBRA_SCENE_BENCH(stochasticIterations, cornell, "cornell");
PENUMBRA_SCENE_BENCH(stochasticIterations, teapots, "teapots.json");
PENUMBRA_SCENE_BENCH(stochasticIterations, room, "room.json");
PENUMBRA_SCENE_BENCH(progressiveIterations, cornell, "cornell");
PENUMBRA_SCENE_BENCH(progressiveIterations, room, "room.json");

}  // namespace

BENCHMARK_MAIN();
