// Ray Engine throughput on the Stanford bunny against Embree, same rays, same run (design doc
// sec. 7). Two workloads: 1024x1024 coherent primary rays from a camera framing the bunny, and
// 1M incoherent diffuse rays (cosine-distributed about the normal at random surface points).
// Prints Mrays/s for each and the ratio Penumbra / Embree (best of rtcIntersect1 and
// rtcIntersect8).
#include "penumbra/io/scene_io.h"
#include "penumbra/raytrace/ray_cache.h"
#include "penumbra/raytrace/ray_engine.h"
#include "penumbra/raytrace/ray_sets.h"

#include <benchmark/benchmark.h>
#include <embree3/rtcore.h>
#include <tbb/parallel_for.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>

namespace {

using namespace penumbra;

struct Workload {
  Mesh mesh;
  RayEngine engine;
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  RayBatch coherent, diffuse;
};

Workload& workload() {
  static Workload w = [] {
    Workload wl;
    const char* mesh_env = std::getenv("PENUMBRA_BENCH_MESH");
    Expected<Scene> s = loadScene(mesh_env ? std::string(mesh_env)
                                           : std::string(PENUMBRA_BENCH_DATA) + "/bunny.ply");
    if (!s) {
      std::fprintf(stderr, "%s\n", s.error().describe().c_str());
      std::exit(2);
    }
    wl.mesh = s->meshes[0];
    wl.engine = RayEngine::build(wl.mesh.positions, wl.mesh.triangles);

    wl.device = rtcNewDevice(nullptr);
    wl.scene = rtcNewScene(wl.device);
    rtcSetSceneBuildQuality(wl.scene, RTC_BUILD_QUALITY_HIGH);
    RTCGeometry g = rtcNewGeometry(wl.device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 12, wl.mesh.positions.size()));
    std::memcpy(v, wl.mesh.positions.data(), wl.mesh.positions.size() * 12);
    auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12, wl.mesh.triangles.size()));
    std::memcpy(idx, wl.mesh.triangles.data(), wl.mesh.triangles.size() * 12);
    rtcCommitGeometry(g);
    rtcAttachGeometry(wl.scene, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(wl.scene);

    // Coherent: a camera framing the bunny. Incoherent: diffuse rays off random surface
    // points (raytrace/ray_sets.h, as `penumbra rays` writes them).
    wl.coherent = cameraRaySet(defaultCamera(*s), 1024, 1024);
    wl.diffuse = diffuseRaySet(wl.mesh.positions, wl.mesh.triangles, 1 << 20, 7, 1e-4f);
    return wl;
  }();
  return w;
}

const RayBatch& raysFor(int which) {
  return which == 0 ? workload().coherent : workload().diffuse;
}

void penumbraTrace(benchmark::State& state) {
  const RayBatch& rays = raysFor(int(state.range(0)));
  const RayEngine& engine = workload().engine;
  HitBatch hits;
  hits.resize(rays.size());
  for (auto _ : state) {
    engine.intersect(rays, hits);
    benchmark::DoNotOptimize(hits.t.data());
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(rays.size()));
}

// The same rays through the ray cache (sec. 5.3): inserted, drained bucket by bucket, traced in
// bucket order (runs of eight similar rays travel as packets), hits scattered back. Counters
// split the time as the paper's Table 3 does: organising rays vs intersecting them.
void penumbraTraceCached(benchmark::State& state) {
  const RayBatch& rays = raysFor(int(state.range(0)));
  const RayEngine& engine = workload().engine;
  HitBatch hits;
  RayCacheStats stats;
  double sort_s = 0.0, trace_s = 0.0;
  for (auto _ : state) {
    traceThroughCache(engine, rays, hits, RayCacheOptions{}, &stats);
    sort_s += stats.insert_seconds + stats.bucket_seconds;
    trace_s += stats.trace_seconds;
    benchmark::DoNotOptimize(hits.t.data());
  }
  state.counters["sort_share"] = sort_s / (sort_s + trace_s);
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(rays.size()));
}

void embreeTrace1(benchmark::State& state) {
  const RayBatch& rays = raysFor(int(state.range(0)));
  RTCScene scene = workload().scene;
  std::vector<int32_t> prim(rays.size());
  for (auto _ : state) {
    tbb::parallel_for(
        tbb::blocked_range<size_t>(0, rays.size(), 256), [&](const tbb::blocked_range<size_t>& r) {
          RTCIntersectContext ctx;
          rtcInitIntersectContext(&ctx);
          for (size_t i = r.begin(); i < r.end(); ++i) {
            RTCRayHit rh;
            rh.ray.org_x = rays.ox[i], rh.ray.org_y = rays.oy[i];
            rh.ray.org_z = rays.oz[i], rh.ray.tnear = rays.tmin[i];
            rh.ray.dir_x = rays.dx[i], rh.ray.dir_y = rays.dy[i];
            rh.ray.dir_z = rays.dz[i], rh.ray.tfar = rays.tmax[i];
            rh.ray.mask = ~0u, rh.ray.flags = 0, rh.ray.time = 0.0f;
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(scene, &ctx, &rh);
            prim[i] = rh.hit.geomID == RTC_INVALID_GEOMETRY_ID ? -1 : int32_t(rh.hit.primID);
          }
        });
    benchmark::DoNotOptimize(prim.data());
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(rays.size()));
}

void embreeTrace8(benchmark::State& state) {
  const RayBatch& rays = raysFor(int(state.range(0)));
  RTCScene scene = workload().scene;
  std::vector<int32_t> prim(rays.size());
  for (auto _ : state) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, rays.size() / 8, 32),
                      [&](const tbb::blocked_range<size_t>& r) {
                        RTCIntersectContext ctx;
                        rtcInitIntersectContext(&ctx);
                        alignas(32) int valid[8] = {-1, -1, -1, -1, -1, -1, -1, -1};
                        for (size_t p = r.begin(); p < r.end(); ++p) {
                          alignas(32) RTCRayHit8 rh;
                          for (int k = 0; k < 8; ++k) {
                            const size_t i = p * 8 + size_t(k);
                            rh.ray.org_x[k] = rays.ox[i], rh.ray.org_y[k] = rays.oy[i];
                            rh.ray.org_z[k] = rays.oz[i], rh.ray.tnear[k] = rays.tmin[i];
                            rh.ray.dir_x[k] = rays.dx[i], rh.ray.dir_y[k] = rays.dy[i];
                            rh.ray.dir_z[k] = rays.dz[i], rh.ray.tfar[k] = rays.tmax[i];
                            rh.ray.mask[k] = ~0u, rh.ray.flags[k] = 0, rh.ray.time[k] = 0.0f;
                            rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
                          }
                          rtcIntersect8(valid, scene, &ctx, &rh);
                          for (int k = 0; k < 8; ++k) {
                            prim[p * 8 + size_t(k)] = rh.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID
                                                          ? -1
                                                          : int32_t(rh.hit.primID[k]);
                          }
                        }
                      });
    benchmark::DoNotOptimize(prim.data());
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(rays.size()));
}

// Acceleration structure builds on the bunny: ours (binned SAH, collapsed to 8-wide nodes, leaf
// blocks) against Embree's high-quality build, both on all threads.
void penumbraBuild(benchmark::State& state) {
  const Mesh& mesh = workload().mesh;
  size_t bytes = 0;
  for (auto _ : state) {
    RayEngine engine = RayEngine::build(mesh.positions, mesh.triangles);
    bytes = engine.memoryBytes();
    benchmark::DoNotOptimize(bytes);
  }
  state.counters["bytes_per_triangle"] = double(bytes) / double(mesh.triangles.size());
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(mesh.triangles.size()));
}

void embreeBuild(benchmark::State& state) {
  const Mesh& mesh = workload().mesh;
  RTCDevice device = workload().device;
  for (auto _ : state) {
    RTCScene scene = rtcNewScene(device);
    rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 12, mesh.positions.size()));
    std::memcpy(v, mesh.positions.data(), mesh.positions.size() * 12);
    auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12, mesh.triangles.size()));
    std::memcpy(idx, mesh.triangles.data(), mesh.triangles.size() * 12);
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(scene);
    rtcReleaseScene(scene);
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(mesh.triangles.size()));
}
BENCHMARK(penumbraBuild)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true);
BENCHMARK(embreeBuild)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true);

// Repetitions in random interleaved order, and ratios of medians: this machine's speed drifts
// by tens of percent over seconds, which would bias a ratio of runs taken one after another.
void rayArgs(benchmark::internal::Benchmark* b) {
  b->Arg(0)->Arg(1)->ArgName("diffuse")->UseRealTime()->Unit(benchmark::kMillisecond);
  b->MinTime(0.5)->Repetitions(7)->ReportAggregatesOnly(true);
}
BENCHMARK(penumbraTrace)->Apply(rayArgs);
BENCHMARK(penumbraTraceCached)->Apply(rayArgs);
BENCHMARK(embreeTrace1)->Apply(rayArgs);
BENCHMARK(embreeTrace8)->Apply(rayArgs);

// Collects rays/s per benchmark so the ratios can be printed after the run.
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& r : runs) {
      if (r.run_type != Run::RT_Aggregate || r.aggregate_name != "median") continue;
      auto it = r.counters.find("items_per_second");
      if (it != r.counters.end()) rates[r.run_name.str()] = it->second.value;
    }
    ConsoleReporter::ReportRuns(runs);
  }
  std::map<std::string, double> rates;
};

}  // namespace

int main(int argc, char** argv) {
  // Interleave repetitions unless the caller chose otherwise.
  std::vector<char*> args(argv, argv + argc);
  char interleave[] = "--benchmark_enable_random_interleaving=true";
  bool has_interleave = false;
  for (char* a : args) has_interleave |= std::strstr(a, "random_interleaving") != nullptr;
  if (!has_interleave) args.insert(args.begin() + 1, interleave);
  argc = int(args.size());
  argv = args.data();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  workload();  // build outside the timings
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  auto rate = [&](const std::string& prefix) {
    for (const auto& [name, value] : reporter.rates) {
      if (name.rfind(prefix, 0) == 0) return value;
    }
    return 0.0;
  };
  for (const char* name : {"diffuse:0", "diffuse:1"}) {
    const std::string suffix = std::string("/") + name + "/";
    const double ours = rate("penumbraTrace" + suffix);
    const double e1 = rate("embreeTrace1" + suffix);
    const double e8 = rate("embreeTrace8" + suffix);
    const double best = std::max(e1, e8);
    const double cached = rate("penumbraTraceCached" + suffix);
    if (cached > 0) {
      std::printf("%s rays through the ray cache: %.2f Mrays/s including the sorting\n",
                  std::string(name) == "diffuse:0" ? "coherent primary" : "incoherent diffuse",
                  cached * 1e-6);
    }
    if (ours > 0 && best > 0) {
      std::printf(
          "%s rays: penumbra %.2f Mrays/s, embree rtcIntersect1 %.2f, rtcIntersect8 %.2f; "
          "ratio to Embree's best %.2fx\n",
          std::string(name) == "diffuse:0" ? "coherent primary" : "incoherent diffuse", ours * 1e-6,
          e1 * 1e-6, e8 * 1e-6, ours / best);
    }
  }
  const double build_ours = rate("penumbraBuild"), build_embree = rate("embreeBuild");
  if (build_ours > 0 && build_embree > 0) {
    std::printf(
        "BVH build (bunny): penumbra %.2f Mtriangles/s, embree (high quality) %.2f; "
        "ratio %.2fx\n",
        build_ours * 1e-6, build_embree * 1e-6, build_ours / build_embree);
  }
  benchmark::Shutdown();
  return 0;
}
