// Ray Engine throughput through the library against Embree, same rays, same run (design doc
// sec. 7), on two scenes: the Stanford bunny (69k triangles) and 16 bunnies on a floor (1.1M
// triangles). Workloads: 1024x1024 coherent primary rays from a camera framing the scene, 1M
// incoherent diffuse rays (cosine-distributed about the normal at random surface points) as
// closest-hit and as occlusion (any-hit) queries. Prints Mrays/s for each and the ratio
// Penumbra / Embree (best of rtcIntersect1 and rtcIntersect8, or rtcOccluded1 and
// rtcOccluded8). bench/trace_vs_embree.py measures `penumbra trace` on ray files made
// elsewhere.
#include "embree_peer.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/raytrace/ray_cache.h"
#include "penumbra/raytrace/ray_engine.h"
#include "penumbra/raytrace/ray_sets.h"

#include <benchmark/benchmark.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <string>

namespace {

using namespace penumbra;

struct Workload {
  Mesh mesh;
  RayEngine engine;
  std::unique_ptr<bench::EmbreePeer> embree;
  RayBatch coherent, diffuse;
};

// 16 copies of the bunny in a 4 x 4 grid, each turned and scaled, on a two-triangle floor.
Mesh manyBunnies(const Mesh& bunny) {
  Mesh out;
  const Bounds3 box = Bounds3::of(bunny.positions);
  const glm::vec3 size = box.extent();
  const float step = 0.9f * std::max(size.x, size.z);
  for (int c = 0; c < 16; ++c) {
    const float angle = 0.7f * float(c), scale = 0.6f + 0.05f * float(c);
    const float cs = std::cos(angle), sn = std::sin(angle);
    const uint32_t base = uint32_t(out.positions.size());
    for (const glm::vec3& p : bunny.positions) {
      const glm::vec3 q = p - glm::vec3(box.center().x, box.lo.y, box.center().z);
      out.positions.push_back(glm::vec3(cs * q.x + sn * q.z, q.y, -sn * q.x + cs * q.z) * scale +
                              glm::vec3(float(c % 4) * step, 0.0f, float(c / 4) * step));
    }
    for (const glm::uvec3& t : bunny.triangles) out.triangles.push_back(t + glm::uvec3(base));
  }
  const Bounds3 all = Bounds3::of(out.positions);
  const uint32_t base = uint32_t(out.positions.size());
  const float m = 0.2f * step;
  out.positions.insert(out.positions.end(), {{all.lo.x - m, all.lo.y, all.lo.z - m},
                                             {all.hi.x + m, all.lo.y, all.lo.z - m},
                                             {all.hi.x + m, all.lo.y, all.hi.z + m},
                                             {all.lo.x - m, all.lo.y, all.hi.z + m}});
  out.triangles.push_back({base, base + 2, base + 1});
  out.triangles.push_back({base, base + 3, base + 2});
  return out;
}

Workload makeWorkload(Mesh mesh, const Camera& camera) {
  Workload wl;
  wl.mesh = std::move(mesh);
  wl.engine = RayEngine::build(wl.mesh.positions, wl.mesh.triangles);
  wl.embree = std::make_unique<bench::EmbreePeer>(wl.mesh.positions, wl.mesh.triangles);
  // Coherent: a camera framing the scene. Incoherent: diffuse rays off random surface points
  // (raytrace/ray_sets.h, as `penumbra rays` writes them), tmin 1e-4 of the diagonal.
  wl.coherent = cameraRaySet(camera, 1024, 1024);
  const float diagonal = glm::length(Bounds3::of(wl.mesh.positions).extent());
  wl.diffuse = diffuseRaySet(wl.mesh.positions, wl.mesh.triangles, 1 << 20, 7, 1e-4f * diagonal);
  return wl;
}

// Workload 0: the bunny; 1: 16 bunnies on a floor.
Workload& workload(int which) {
  static std::vector<Workload> all = [] {
    const char* mesh_env = std::getenv("PENUMBRA_BENCH_MESH");
    Expected<Scene> s = loadScene(mesh_env ? std::string(mesh_env)
                                           : std::string(PENUMBRA_BENCH_DATA) + "/bunny.ply");
    if (!s) {
      std::fprintf(stderr, "%s\n", s.error().describe().c_str());
      std::exit(2);
    }
    std::vector<Workload> w;
    w.push_back(makeWorkload(s->meshes[0], defaultCamera(*s)));
    Scene many;
    many.meshes.push_back(manyBunnies(s->meshes[0]));
    many.materials = s->materials;
    w.push_back(makeWorkload(many.meshes[0], defaultCamera(many)));
    return w;
  }();
  return all[size_t(which)];
}

// range(0): scene; range(1): 0 coherent, 1 diffuse.
const RayBatch& raysFor(const benchmark::State& state) {
  Workload& w = workload(int(state.range(0)));
  return state.range(1) == 0 ? w.coherent : w.diffuse;
}

void penumbraTrace(benchmark::State& state) {
  const RayBatch& rays = raysFor(state);
  const RayEngine& engine = workload(int(state.range(0))).engine;
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
  const RayBatch& rays = raysFor(state);
  const RayEngine& engine = workload(int(state.range(0))).engine;
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
  const RayBatch& rays = raysFor(state);
  const bench::EmbreePeer& peer = *workload(int(state.range(0))).embree;
  HitBatch out;
  out.resize(rays.size());
  for (auto _ : state) {
    peer.intersect1(rays, out);
    benchmark::DoNotOptimize(out.t.data());
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(rays.size()));
}

void embreeTrace8(benchmark::State& state) {
  const RayBatch& rays = raysFor(state);
  const bench::EmbreePeer& peer = *workload(int(state.range(0))).embree;
  HitBatch out;
  out.resize(rays.size());
  for (auto _ : state) {
    peer.intersect8(rays, out);
    benchmark::DoNotOptimize(out.t.data());
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(rays.size()));
}

// Occlusion (any hit) of the diffuse rays: shadow and visibility queries.
void penumbraOccluded(benchmark::State& state) {
  const RayBatch& rays = raysFor(state);
  const RayEngine& engine = workload(int(state.range(0))).engine;
  std::vector<uint8_t> occluded(rays.size());
  for (auto _ : state) {
    engine.occluded(rays, occluded);
    benchmark::DoNotOptimize(occluded.data());
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(rays.size()));
}

void embreeOccluded1(benchmark::State& state) {
  const RayBatch& rays = raysFor(state);
  const bench::EmbreePeer& peer = *workload(int(state.range(0))).embree;
  std::vector<uint8_t> out(rays.size());
  for (auto _ : state) {
    peer.occluded1(rays, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(rays.size()));
}

void embreeOccluded8(benchmark::State& state) {
  const RayBatch& rays = raysFor(state);
  const bench::EmbreePeer& peer = *workload(int(state.range(0))).embree;
  std::vector<uint8_t> out(rays.size());
  for (auto _ : state) {
    peer.occluded8(rays, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(rays.size()));
}

// Acceleration structure builds on the bunny: ours (binned SAH, collapsed to 8-wide nodes, leaf
// blocks) against Embree's high-quality build, both on all threads.
void penumbraBuild(benchmark::State& state) {
  const Mesh& mesh = workload(0).mesh;
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
  const Mesh& mesh = workload(0).mesh;
  RTCDevice device = workload(0).embree->device();
  for (auto _ : state) {
    const bench::EmbreePeer peer(mesh.positions, mesh.triangles, device);
    benchmark::DoNotOptimize(&peer);
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
  b->ArgNames({"scene", "rays"})->Args({0, 0})->Args({0, 1})->Args({1, 0})->Args({1, 1});
  b->UseRealTime()->Unit(benchmark::kMillisecond);
  b->MinTime(0.5)->Repetitions(7)->ReportAggregatesOnly(true);
}
void diffuseArgs(benchmark::internal::Benchmark* b) {
  b->ArgNames({"scene", "rays"})->Args({0, 1})->Args({1, 1});
  b->UseRealTime()->Unit(benchmark::kMillisecond);
  b->MinTime(0.5)->Repetitions(7)->ReportAggregatesOnly(true);
}
BENCHMARK(penumbraTrace)->Apply(rayArgs);
BENCHMARK(penumbraTraceCached)
    ->ArgNames({"scene", "rays"})
    ->Args({0, 0})
    ->Args({0, 1})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond)
    ->MinTime(0.5)
    ->Repetitions(7)
    ->ReportAggregatesOnly(true);
BENCHMARK(embreeTrace1)->Apply(rayArgs);
BENCHMARK(embreeTrace8)->Apply(rayArgs);
BENCHMARK(penumbraOccluded)->Apply(diffuseArgs);
BENCHMARK(embreeOccluded1)->Apply(diffuseArgs);
BENCHMARK(embreeOccluded8)->Apply(diffuseArgs);

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
  workload(0);  // build outside the timings
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  auto rate = [&](const std::string& prefix) {
    for (const auto& [name, value] : reporter.rates) {
      if (name.rfind(prefix, 0) == 0) return value;
    }
    return 0.0;
  };
  const char* scene_names[] = {"bunny", "16 bunnies (1.1M triangles)"};
  for (int scene = 0; scene < 2; ++scene) {
    for (int set = 0; set < 2; ++set) {
      const std::string suffix =
          "/scene:" + std::to_string(scene) + "/rays:" + std::to_string(set) + "/";
      const char* what = set == 0 ? "coherent primary" : "incoherent diffuse";
      const double cached = rate("penumbraTraceCached" + suffix);
      if (cached > 0) {
        std::printf("%s, %s rays through the ray cache: %.2f Mrays/s including the sorting\n",
                    scene_names[scene], what, cached * 1e-6);
      }
      const double ours = rate("penumbraTrace" + suffix);
      const double e1 = rate("embreeTrace1" + suffix), e8 = rate("embreeTrace8" + suffix);
      if (ours > 0 && std::max(e1, e8) > 0) {
        std::printf(
            "%s, %s rays: penumbra %.2f Mrays/s, embree rtcIntersect1 %.2f, rtcIntersect8 "
            "%.2f; ratio to Embree's best %.2fx\n",
            scene_names[scene], what, ours * 1e-6, e1 * 1e-6, e8 * 1e-6, ours / std::max(e1, e8));
      }
      const double occ = rate("penumbraOccluded" + suffix);
      const double o1 = rate("embreeOccluded1" + suffix), o8 = rate("embreeOccluded8" + suffix);
      if (occ > 0 && std::max(o1, o8) > 0) {
        std::printf(
            "%s, %s rays, occlusion: penumbra %.2f Mrays/s, embree rtcOccluded1 %.2f, "
            "rtcOccluded8 %.2f; ratio to Embree's best %.2fx\n",
            scene_names[scene], what, occ * 1e-6, o1 * 1e-6, o8 * 1e-6, occ / std::max(o1, o8));
      }
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
