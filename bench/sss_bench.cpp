// The subsurface method's Table 1 (Carr, Hall, Hart 2003, sec. 5) on this machine: the built-in
// `sss` scene (the Stanford bunny in marble, a point light orbiting it) at 256^2, 512^2 and
// (with PENUMBRA_BENCH_SSS_1024=1, which takes minutes of link building) 1024^2 atlases, 16
// adaptive links, a 512 x 512 image at one sample per pixel (the paper's one fragment per
// pixel), every pass on the CPU's threads. Per frame: the three passes' times and shares of the
// frame, frames per second; once per atlas, the links' precomputation time (the paper: about 9 s
// at 1024^2). The links are cached under the build directory (subsurface/sss_cache.h), so only
// the first run pays for them; `links_cached` says which it was. Each atlas also runs with pass 1
// lit without shadow rays, as the paper's pass 1 was (the OpenGL lighting model in a vertex
// program, sec. 4.2.2), to compare like with like.
//
// There is no peer that computes the same thing: the brute-force gather the links replace is
// quadratic (3e10 pairs at 512^2) and is timed at small sizes in tests/subsurface.
#include "penumbra/core/parallel.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/render/sss_frames.h"
#include "penumbra/scene/scene.h"
#include "penumbra/subsurface/sss.h"

#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>

namespace {

using namespace penumbra;

struct Setup {
  Scene scene;
  std::unique_ptr<SssSolver> solver;
  std::unique_ptr<SssFrames> frames;
};

Setup& setupFor(int atlas, bool shadows) {
  static std::map<std::pair<int, bool>, std::unique_ptr<Setup>> cache;
  const std::pair<int, bool> key{atlas, shadows};
  if (!cache[key]) {
    cache.clear();  // one atlas alive at a time
    auto s = std::make_unique<Setup>();
    Expected<Scene> scene = loadScene("sss");
    if (!scene) std::abort();
    s->scene = std::move(*scene);
    SssOptions o;
    o.resolution.size = atlas;
    o.shadows = shadows;
    o.cache_directory = (std::filesystem::current_path() / "sss-bench-cache").string();
    Expected<SssSolver> solver = SssSolver::build(s->scene, o);
    if (!solver) std::abort();
    s->solver = std::make_unique<SssSolver>(std::move(*solver));
    SssViewSettings view;
    view.width = view.height = 512;
    view.spp = 1;
    const Camera camera = s->scene.camera ? *s->scene.camera : defaultCamera(s->scene);
    Expected<SssFrames> frames = SssFrames::create(*s->solver, camera, view, false);
    if (!frames) std::abort();
    s->frames = std::make_unique<SssFrames>(std::move(*frames));
    cache[key] = std::move(s);
  }
  return *cache[key];
}

void BM_SssFrame(benchmark::State& state) {
  const int atlas = int(state.range(0));
  Setup& s = setupFor(atlas, state.range(1) != 0);
  const glm::vec3 centre = sceneCentre(s.scene);
  double pass[3] = {0.0, 0.0, 0.0};
  int frame = 0;
  for (auto _ : state) {
    // The light moves every frame: a 64-frame orbit.
    const std::vector<Light> lights =
        orbitLights(s.scene.lights, centre, 2.0f * 3.14159265f * float(frame++ % 64) / 64.0f);
    Expected<SssFrame> f = s.frames->render(lights);
    if (!f) state.SkipWithError("frame failed");
    benchmark::DoNotOptimize(f->image.pixels.data());
    pass[0] += f->times.irradiance;
    pass[1] += f->times.gather;
    pass[2] += f->times.image;
  }
  const double n = double(state.iterations());
  const double total = pass[0] + pass[1] + pass[2];
  state.counters["texels"] = double(s.solver->surface().elementCount());
  state.counters["pass1_ms"] = 1e3 * pass[0] / n;
  state.counters["pass2_ms"] = 1e3 * pass[1] / n;
  state.counters["pass3_ms"] = 1e3 * pass[2] / n;
  state.counters["pass1_share"] = pass[0] / total;
  state.counters["pass2_share"] = pass[1] / total;
  state.counters["pass3_share"] = pass[2] / total;
  state.counters["fps"] = n / total;
  state.counters["links_s"] = s.solver->links().seconds;
  state.counters["links_cached"] = s.solver->linksFromCache() ? 1.0 : 0.0;
  state.counters["threads"] = double(threadCount());
}

// Arguments: the atlas size, and whether pass 1 traces shadow rays (1, Penumbra's default) or
// lights without them (0, as the paper's vertex program did).
void atlases(benchmark::internal::Benchmark* b) {
  b->ArgNames({"atlas", "shadows"});
  for (int shadows : {1, 0}) {
    b->Args({256, shadows})->Args({512, shadows});
    if (const char* big = std::getenv("PENUMBRA_BENCH_SSS_1024"); big && *big == '1') {
      b->Args({1024, shadows});
    }
  }
}

BENCHMARK(BM_SssFrame)->Apply(atlases)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
