// Matrix radiosity throughput (Carr, Hall, Hart 2003, sec. 3.1, Fig. 4), against a STREAM-style
// triad measured in the same run (design doc sec. 7):
//  - triad: a[i] = b[i] + s c[i] over arrays far larger than the caches, all threads; its
//    bandwidth counts the 12 bytes per element STREAM counts;
//  - Jacobi (eq. 4) matrix-vector bandwidth: bytes of the stored matrix read per iteration over
//    the iteration's time, fp32 and fp16 storage, all threads;
//  - iterations per second against N (500 to 8000) for CPU Jacobi and CPU Gauss-Seidel: the
//    shape of the paper's Fig. 4 on this machine;
//  - form-factor rate (element pairs per second) against N on the Cornell box.
// The systems for the solver timings are synthetic (random form factors with rows summing to
// 0.9): the solvers' cost does not depend on the values.
#include "penumbra/core/check.h"
#include "penumbra/core/rng.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/radiosity/form_factors.h"
#include "penumbra/radiosity/matrix_solver.h"
#include "penumbra/scene/builtin.h"

#include <benchmark/benchmark.h>
#include <tbb/parallel_for.h>

#include <cstdio>
#include <cstring>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace {

using namespace penumbra;

// A synthetic N x N system: random non-negative form factors, rows summing to 0.9, rho 0.7,
// one emitter in eight.
RadiositySystem& systemFor(uint32_t n, MatrixPrecision precision) {
  static std::map<std::pair<uint32_t, int>, std::unique_ptr<RadiositySystem>> cache;
  auto& slot = cache[{n, int(precision)}];
  if (!slot) {
    // Keep at most one large system alive at a time.
    for (auto& [key, sys] : cache) {
      if (sys && key.first >= 4000) sys.reset();
    }
    FormFactorMatrix f;
    f.n = n;
    f.f.resize(size_t(n) * n);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t i = r.begin(); i < r.end(); ++i) {
        Rng rng(1, i);
        double sum = 0.0;
        float* row = &f.f[i * n];
        for (size_t j = 0; j < n; ++j) sum += row[j] = j == i ? 0.0f : rng.uniform();
        const float scale = float(0.9 / sum);
        for (size_t j = 0; j < n; ++j) row[j] *= scale;
      }
    });
    slot = std::make_unique<RadiositySystem>(std::move(f), precision);
    for (uint32_t i = 0; i < n; ++i) {
      slot->reflectance[i] = glm::vec3(0.7f);
      slot->emission[i] = i % 8 == 0 ? glm::vec3(10.0f) : glm::vec3(0.0f);
    }
  }
  return *slot;
}

void triad(benchmark::State& state) {
  const size_t n = size_t(1) << 25;  // 3 x 128 MiB
  static std::vector<float> a(n), b(n, 1.0f), c(n, 2.0f);
  const float s = 3.0f;
  for (auto _ : state) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1 << 16),
                      [&](const tbb::blocked_range<size_t>& r) {
                        float* __restrict pa = a.data();
                        const float* __restrict pb = b.data();
                        const float* __restrict pc = c.data();
                        for (size_t i = r.begin(); i < r.end(); ++i) pa[i] = pb[i] + s * pc[i];
                      });
    benchmark::DoNotOptimize(a.data());
    benchmark::ClobberMemory();
  }
  state.SetBytesProcessed(int64_t(state.iterations()) * int64_t(n) * 12);
}

// One Jacobi iteration; bytes = the stored matrix.
void jacobi(benchmark::State& state) {
  const uint32_t n = uint32_t(state.range(0));
  const MatrixPrecision precision =
      state.range(1) ? MatrixPrecision::kFp16 : MatrixPrecision::kFp32;
  const RadiositySystem& sys = systemFor(n, precision);
  std::vector<glm::vec3> b(n, glm::vec3(1.0f)), next(n);
  for (auto _ : state) {
    benchmark::DoNotOptimize(jacobiStep(sys, b, next));
    b.swap(next);
  }
  state.SetBytesProcessed(int64_t(state.iterations()) * int64_t(sys.matrixBytes()));
  state.SetItemsProcessed(int64_t(state.iterations()));  // iterations per second
}

void gaussSeidel(benchmark::State& state) {
  const uint32_t n = uint32_t(state.range(0));
  const RadiositySystem& sys = systemFor(n, MatrixPrecision::kFp32);
  std::vector<glm::vec3> b(n, glm::vec3(1.0f));
  for (auto _ : state) benchmark::DoNotOptimize(gaussSeidelSweep(sys, b));
  state.SetBytesProcessed(int64_t(state.iterations()) * int64_t(sys.matrixBytes()));
  state.SetItemsProcessed(int64_t(state.iterations()));
}

// The room of scenes/room.json (the bunny scan, a teapot, quads) at the default lightmap density:
// form factors between the clusters of a cut of N (the bar: N = 5000 solved within 15 s,
// form factors included).
const RadiositySurface& roomSurface() {
  static const RadiositySurface surface = [] {
    Expected<Scene> room = loadScene(PENUMBRA_BENCH_SCENES "/room.json");
    PENUMBRA_CHECK(room.ok());
    LightmapResolution res;
    Expected<ChartAtlasOptions> ao = lightmapAtlasOptions(*room, res);
    PENUMBRA_CHECK(ao.ok());
    Expected<RadiositySurface> s = RadiositySurface::build(*room, *ao, true);
    PENUMBRA_CHECK(s.ok());
    return std::move(*s);
  }();
  return surface;
}

void formFactors(benchmark::State& state) {
  const RadiositySurface& surface = roomSurface();
  const std::vector<ClusterRef> cut = surface.hierarchy.cut(size_t(state.range(0)));
  FormFactorStats stats;
  for (auto _ : state) {
    Expected<FormFactorMatrix> f = computeFormFactors(surface, cut, FormFactorOptions{}, &stats);
    benchmark::DoNotOptimize(f->f.data());
  }
  state.counters["clusters"] = double(cut.size());
  state.counters["rays_per_pair"] = double(stats.rays) / double(stats.pairs);
  state.counters["refined_per_pair"] = double(stats.refined) / double(stats.pairs);
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(stats.pairs));
}

BENCHMARK(triad)->Repetitions(5)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(jacobi)
    ->ArgsProduct({{500, 1000, 2000, 4000, 8000}, {0}})
    ->Args({8000, 1})
    ->Args({4000, 1})
    ->ArgNames({"n", "fp16"})
    ->Repetitions(5)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(gaussSeidel)
    ->Arg(500)
    ->Arg(1000)
    ->Arg(2000)
    ->Arg(4000)
    ->Arg(8000)
    ->ArgName("n")
    ->Repetitions(5)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(formFactors)
    ->Arg(1000)
    ->Arg(2000)
    ->Arg(5000)
    ->ArgName("n")
    ->Iterations(1)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

class Reporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& r : runs) {
      // Medians of repeated benchmarks, single runs of the others.
      if (r.run_type == Run::RT_Aggregate && r.aggregate_name != "median") continue;
      if (r.run_type != Run::RT_Aggregate && r.repetitions > 1) continue;
      Entry& e = entries[r.run_name.str()];
      auto bytes = r.counters.find("bytes_per_second");
      auto items = r.counters.find("items_per_second");
      if (bytes != r.counters.end()) e.bytes = bytes->second.value;
      if (items != r.counters.end()) e.items = items->second.value;
      auto el = r.counters.find("elements");
      if (el != r.counters.end()) e.elements = el->second.value;
    }
    ConsoleReporter::ReportRuns(runs);
  }
  struct Entry {
    double bytes = 0, items = 0, elements = 0;
  };
  std::map<std::string, Entry> entries;
};

}  // namespace

int main(int argc, char** argv) {
  // Repetitions interleaved at random (the machine's speed drifts), ratios of medians.
  std::vector<char*> args(argv, argv + argc);
  char interleave[] = "--benchmark_enable_random_interleaving=true";
  bool has_interleave = false;
  for (char* a : args) has_interleave |= std::strstr(a, "random_interleaving") != nullptr;
  if (!has_interleave) args.insert(args.begin() + 1, interleave);
  argc = int(args.size());
  argv = args.data();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  Reporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  auto find = [&](const std::string& prefix) -> const Reporter::Entry* {
    for (const auto& [name, e] : reporter.entries) {
      if (name.rfind(prefix, 0) == 0) return &e;
    }
    return nullptr;
  };
  const Reporter::Entry* t = find("triad");
  const Reporter::Entry* j32 = find("jacobi/n:8000/fp16:0");
  const Reporter::Entry* j16 = find("jacobi/n:8000/fp16:1");
  if (t && j32 && j16) {
    std::printf(
        "triad %.2f GB/s; Jacobi N=8000 fp32 %.2f GB/s (%.0f%% of triad, %.2f it/s), "
        "fp16 %.2f GB/s (%.2f it/s, %.2fx the fp32 iteration rate)\n",
        t->bytes * 1e-9, j32->bytes * 1e-9, 100.0 * j32->bytes / t->bytes, j32->items,
        j16->bytes * 1e-9, j16->items, j16->items / j32->items);
  }
  std::printf("Fig. 4 (iterations/s): n, jacobi fp32, gauss-seidel\n");
  for (int n : {500, 1000, 2000, 4000, 8000}) {
    const Reporter::Entry* jj = find("jacobi/n:" + std::to_string(n) + "/fp16:0");
    const Reporter::Entry* gg = find("gaussSeidel/n:" + std::to_string(n));
    if (jj && gg) std::printf("%d, %.2f, %.2f\n", n, jj->items, gg->items);
  }
  std::printf("form factors (Cornell box): elements, Mpairs/s\n");
  for (int n : {250, 500, 1000, 2000}) {
    const Reporter::Entry* f = find("formFactors/target:" + std::to_string(n));
    if (f) std::printf("%.0f, %.3f\n", f->elements, f->items * 1e-6);
  }
  benchmark::Shutdown();
  return 0;
}
