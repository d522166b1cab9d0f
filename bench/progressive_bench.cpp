// Progressive radiosity in a lightmap (Wallner sec. 2-3) on the CPU: time per iteration, elements
// shot and receiver elements updated per second, shadow rays per second, and memory per element,
// against the element count, on the teapot scene (the Cornell box with four Utah teapots, 9,060
// triangles: the scale of the paper's Table 1 scenes) from 40,000 to 4 M lightmap texels, and on
// the Cornell box (36 triangles) at 10,000 (the teapots' 9,060 charts cannot hold fewer than
// 27,180 texels).
// Each run builds the solver and times its first 8 iterations (the light, then the walls: the
// largest shooters). The peer of the design doc's sec. 7 is the Ray Engine's own incoherent-ray
// rate (ray_bench); here the rays/s column shows what the shooting reaches with packets.
#include "penumbra/io/scene_io.h"
#include "penumbra/radiosity/progressive.h"

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <string>

namespace {

using namespace penumbra;

// "cornell" (built in) or a file under scenes/.
const Scene& sceneNamed(const std::string& name) {
  static std::map<std::string, Scene> scenes;
  auto it = scenes.find(name);
  if (it != scenes.end()) return it->second;
  Expected<Scene> s =
      loadScene(name == "cornell" ? name : std::string(PENUMBRA_BENCH_SCENES) + "/" + name);
  if (!s) {
    std::fprintf(stderr, "%s\n", s.error().describe().c_str());
    std::abort();
  }
  return scenes.emplace(name, std::move(*s)).first->second;
}

// Resident set size now, from /proc/self/statm (bytes).
double residentBytes() {
  std::ifstream statm("/proc/self/statm");
  double pages = 0.0, resident = 0.0;
  statm >> pages >> resident;
  return resident * 4096.0;
}

void progressiveIterations(benchmark::State& state, const std::string& scene_name) {
  const Scene& scene = sceneNamed(scene_name);
  ProgressiveOptions o;
  o.atlas.texel_density = std::sqrt(double(state.range(0)) / faceArea(scene));
  o.convergence = 0.0;
  constexpr int kIterations = 8;
  double seconds = 0.0, shot = 0.0, rays = 0.0, bytes = 0.0, elements = 0.0;
  for (auto _ : state) {
    const double before = residentBytes();
    Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(scene, o);
    if (!pr) {
      state.SkipWithError(pr.error().describe().c_str());
      return;
    }
    elements = double(pr->elementCount());
    for (int i = 0; i < kIterations; ++i) {
      const uint32_t shooter = pr->selectShooter();
      if (shooter != ProgressiveRadiosity::kLights) {
        shot += double(pr->shooterEnd(shooter) - pr->shooterBegin(shooter));
      }
      const ProgressiveIteration it = pr->shoot(shooter);
      seconds += it.seconds;
      rays += double(it.rays);
    }
    bytes = residentBytes() - before;
  }
  const double iterations = double(state.iterations()) * kIterations;
  state.counters["elements"] = elements;
  state.counters["s_per_iteration"] = seconds / iterations;
  state.counters["shot_elements_per_s"] = shot / seconds;
  state.counters["receiver_updates_per_s"] = elements * iterations / seconds;
  state.counters["mrays_per_s"] = rays / seconds * 1e-6;
  state.counters["bytes_per_element"] = bytes / elements;
  std::printf(
      "progressive, %s, %.0f elements: %.3f s per iteration, %.3g elements shot/s, %.3g "
      "receiver updates/s, %.1f Mrays/s, %.0f bytes per element (resident)\n",
      scene_name.c_str(), elements, seconds / iterations, shot / seconds,
      elements * iterations / seconds, rays / seconds * 1e-6, bytes / elements);
}

void progressiveCornell(benchmark::State& state) {
  progressiveIterations(state, "cornell");
}
void progressiveTeapots(benchmark::State& state) {
  progressiveIterations(state, "teapots.json");
}

BENCHMARK(progressiveCornell)->Arg(10000)->Iterations(1)->UseRealTime()->Unit(benchmark::kSecond);
BENCHMARK(progressiveTeapots)
    ->Arg(40000)
    ->Arg(160000)
    ->Arg(640000)
    ->Arg(2560000)
    ->Arg(4000000)
    ->Iterations(1)
    ->UseRealTime()
    ->Unit(benchmark::kSecond);

}  // namespace

BENCHMARK_MAIN();
