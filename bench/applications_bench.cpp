// The Ray Engine paper's applications (Carr, Hall, Hart 2002, Table 1) measured the same way:
// Whitted ray tracing, path tracing (the wavefront tracer) and photon mapping (shooting, and the
// image with its final gather) on scenes/cornell-glass.json, each through the Ray Engine's CPU
// back end and, where an OpenGL context exists, its GPU kernel and CPU/GPU split (Mesa llvmpipe
// here: software, not GPU timings).
//
// The peer (design doc sec. 7): Embree, tracing the very batches the application sent to the
// Ray Engine, recorded in a first run, closest-hit and occlusion, the better of its single-ray
// and 8-ray packet entry points. The ratio application rays/s over Embree's on those rays says
// how close the whole method (shading, sampling, the photon map's lookups) comes to pure
// tracing by the best CPU peer.
#include "embree_peer.h"
#include "penumbra/core/timer.h"
#include "penumbra/gpu/context.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/raytrace/path_tracer.h"
#include "penumbra/raytrace/photon_map.h"
#include "penumbra/raytrace/ray_queries.h"
#include "penumbra/raytrace/whitted.h"

#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>

namespace {

using namespace penumbra;

// Passes batches on to another back end, keeping a copy of each for the peer to replay.
class RecordingQueries : public RayQueries {
 public:
  explicit RecordingQueries(RayQueries& inner) : inner_(inner) {}
  Status intersect(const RayBatch& rays, HitBatch& hits) override {
    closest.push_back(rays);
    return inner_.intersect(rays, hits);
  }
  Status occluded(const RayBatch& rays, std::vector<uint8_t>& occluded) override {
    shadow.push_back(rays);
    return inner_.occluded(rays, occluded);
  }
  std::vector<RayBatch> closest, shadow;

 private:
  RayQueries& inner_;
};

struct Workload {
  Scene scene;
  std::unique_ptr<WhittedTracer> whitted;
  std::unique_ptr<PathTracer> tracer;
  std::unique_ptr<bench::EmbreePeer> embree;
  std::unique_ptr<GlContext> gl;
  std::map<std::string, std::unique_ptr<OwnedRayQueries>> back_ends;
};

Workload& workload() {
  static Workload w = [] {
    Workload out;
    Expected<Scene> s = loadScene(std::string(PENUMBRA_BENCH_SCENES) + "/cornell-glass.json");
    if (!s) {
      std::fprintf(stderr, "%s\n", s.error().describe().c_str());
      std::exit(2);
    }
    out.scene = std::move(*s);
    out.whitted = std::make_unique<WhittedTracer>(out.scene);
    out.tracer = std::make_unique<PathTracer>(out.scene);
    const SceneGeometry& g = out.whitted->geometry();
    out.embree = std::make_unique<bench::EmbreePeer>(g.positions, g.triangles);
    Expected<std::unique_ptr<OwnedRayQueries>> cpu = OwnedRayQueries::make("cpu", g);
    out.back_ends["cpu"] = std::move(*cpu);
    Expected<std::unique_ptr<GlContext>> gl = GlContext::createHeadless();
    if (gl) {
      out.gl = std::move(*gl);
      for (const char* b : {"gpu", "hybrid"}) {
        Expected<std::unique_ptr<OwnedRayQueries>> q = OwnedRayQueries::make(b, g);
        if (q) out.back_ends[b] = std::move(*q);
      }
    }
    return out;
  }();
  return w;
}

// The applications, one run each through `q`; each returns the rays it traced.
WhittedSettings whittedSettings() {
  WhittedSettings s;
  s.width = s.height = 128;
  s.spp = 1;
  s.light_samples = 4;
  return s;
}

PhotonSettings photonSettings() {
  PhotonSettings p;
  p.photons = 100000;
  p.caustic_photons = 100000;
  p.final_gather = 8;
  return p;
}

uint64_t runWhitted(RayQueries& q) {
  Workload& w = workload();
  WhittedStats stats;
  Expected<Image> img = w.whitted->render(*w.scene.camera, whittedSettings(), q, &stats);
  benchmark::DoNotOptimize(img->pixels.data());
  return stats.rays + stats.shadow_rays;
}

uint64_t runPathTrace(RayQueries& q) {
  Workload& w = workload();
  PathTracerSettings s;
  s.width = s.height = 128;
  s.spp = 2;
  PathTracerStats stats;
  Expected<Image> img = w.tracer->renderWavefront(*w.scene.camera, s, q, &stats);
  benchmark::DoNotOptimize(img->pixels.data());
  return stats.rays;
}

// Pass 1 in full: the photons traced and stored, the kd-trees built, the gather's radiance
// precomputed; the seconds of each part go to counters.
PhotonStats g_last_photons;
uint64_t runPhotonShoot(RayQueries& q) {
  Workload& w = workload();
  Expected<PhotonMaps> maps =
      shootPhotons(w.scene, w.whitted->geometry(), photonSettings(), q, &g_last_photons);
  benchmark::DoNotOptimize(maps->global.photons().data());
  return g_last_photons.rays;
}

uint64_t runPhotonRender(RayQueries& q) {
  Workload& w = workload();
  static PhotonMaps maps = [&] {
    Expected<PhotonMaps> m =
        shootPhotons(w.scene, w.whitted->geometry(), photonSettings(), *w.back_ends.at("cpu"));
    return std::move(*m);
  }();
  uint64_t gather = 0;
  WhittedStats stats;
  Expected<Image> img =
      w.whitted->render(*w.scene.camera, whittedSettings(), q, &stats, {},
                        photonShading(w.whitted->geometry(), maps, photonSettings(), &gather));
  benchmark::DoNotOptimize(img->pixels.data());
  return stats.rays + stats.shadow_rays + gather;
}

using Application = uint64_t (*)(RayQueries&);
const std::map<int, std::pair<const char*, Application>> kApplications = {
    {0, {"whitted", runWhitted}},
    {1, {"pathtrace", runPathTrace}},
    {2, {"photon_shoot", runPhotonShoot}},
    {3, {"photon_render", runPhotonRender}}};
const char* kBackEnds[] = {"cpu", "gpu", "hybrid"};

// range(0): the application; range(1): the back end.
void application(benchmark::State& state) {
  Workload& w = workload();
  const auto& [name, run] = kApplications.at(int(state.range(0)));
  const char* back_end = kBackEnds[state.range(1)];
  auto it = w.back_ends.find(back_end);
  if (it == w.back_ends.end()) {
    state.SkipWithError("no OpenGL 4.5 context");
    return;
  }
  state.SetLabel(std::string(name) + " / " + back_end);
  uint64_t rays = 0;
  for (auto _ : state) rays += run(*it->second);
  state.counters["rays_per_s"] = benchmark::Counter(double(rays), benchmark::Counter::kIsRate);
  if (int(state.range(0)) == 2) {
    // Photons emitted per second of the whole pass, and of their tracing alone; the shares of
    // the kd-trees and the precomputed radiance.
    const PhotonSettings p = photonSettings();
    const PhotonStats& s = g_last_photons;
    const double whole = s.seconds + s.build_seconds + s.precompute_seconds;
    state.counters["photons_per_s"] =
        benchmark::Counter(double(state.iterations()) * double(p.photons + p.caustic_photons),
                           benchmark::Counter::kIsRate);
    state.counters["traced_photons_per_s"] = double(p.photons + p.caustic_photons) / s.seconds;
    state.counters["trace_share"] = s.seconds / whole;
    state.counters["tree_share"] = s.build_seconds / whole;
    state.counters["precompute_share"] = s.precompute_seconds / whole;
  }
}

// Embree on the batches the application sent (recorded once through the CPU back end):
// range(1) 0 its single rays, 1 its 8-ray packets; 2 the Ray Engine's CPU back end alone on the
// same batches (what the application spends outside tracing is the rest of its time).
void embreeReplay(benchmark::State& state) {
  Workload& w = workload();
  const auto& [name, run] = kApplications.at(int(state.range(0)));
  RecordingQueries recording(*w.back_ends.at("cpu"));
  run(recording);
  state.SetLabel(std::string(name) +
                 (state.range(1) == 2 ? " rays / ray engine" : " rays / embree"));
  const RayEngine& engine = w.whitted->geometry().engine;
  HitBatch hits;
  std::vector<uint8_t> occluded;
  uint64_t rays = 0;
  for (auto _ : state) {
    for (const RayBatch& b : recording.closest) {
      hits.resize(b.size());
      if (state.range(1) == 2) {
        engine.intersect(b, hits);
      } else if (state.range(1) == 1) {
        w.embree->intersect8(b, hits);
      } else {
        w.embree->intersect1(b, hits);
      }
      rays += b.size();
    }
    for (const RayBatch& b : recording.shadow) {
      occluded.resize(b.size());
      if (state.range(1) == 2) {
        engine.occluded(b, occluded);
      } else if (state.range(1) == 1) {
        w.embree->occluded8(b, occluded);
      } else {
        w.embree->occluded1(b, occluded);
      }
      rays += b.size();
    }
    benchmark::DoNotOptimize(hits.t.data());
  }
  state.counters["rays_per_s"] = benchmark::Counter(double(rays), benchmark::Counter::kIsRate);
}

BENCHMARK(application)
    ->ArgsProduct({{0, 1, 2, 3}, {0, 1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(1.0);
BENCHMARK(embreeReplay)
    ->ArgsProduct({{0, 1, 2, 3}, {0, 1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(1.0);

}  // namespace

BENCHMARK_MAIN();
