// Subsurface light propagation volumes' Table 1 (Børlum et al. 2011, sec. 5) on this machine's
// CPU: the built-in `lpv` scene (the 69,451-triangle marble bunny) with one point light behind
// it or a second at the side, lights orbiting (a new position every frame), a 512 x 512 image at
// one sample per pixel; 32^3 and 64^3 grids, 8 and 32 propagation steps. Per frame: the
// milliseconds of voxelisation, injection (the reflective shadow maps, 256^2 texels each),
// propagation and shading, frames per second, and the grid's memory. The geometry does not move,
// so after the first frame the voxelisation and the camera's hits are kept (the paper's
// rasterised pipeline redraws them; its Table 1 does not count a voxelisation). The `blobs`
// animation remeshes every frame and pays for everything. BM_LpvPropagate times the propagation
// alone on the bunny's cells (the goal: 32^3, 8 steps, at most 2 ms on two cores).
// BM_LpvSurroundings times the injection of a sky's light through gathered surface points.
//
// The peer in the same run is the other real-time subsurface method on the same scene and image:
// the dipole through hierarchical links (Carr et al. 2003, subsurface/sss.h), whose frames cost
// its three passes once its links are built (cached under the build directory).
//   build/bin/lpv_bench
#include "penumbra/io/scene_io.h"
#include "penumbra/render/sss_frames.h"
#include "penumbra/scene/animation.h"
#include "penumbra/subsurface/lpv.h"
#include "penumbra/subsurface/lpv_volume.h"
#include "penumbra/subsurface/sss.h"

#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <memory>
#include <numbers>

namespace {

using namespace penumbra;

Scene bunny(int lights) {
  Expected<Scene> s = loadScene("lpv");
  if (!s) std::abort();
  if (lights > 1) s->lights.push_back(PointLight{glm::vec3(0.45f, 0.12f, 0.05f), glm::vec3(0.2f)});
  return std::move(*s);
}

void report(benchmark::State& state, const LpvFrameTimes& sum, double frames, uint64_t bytes) {
  state.counters["voxelise_ms"] = 1e3 * sum.voxelise / frames;
  state.counters["inject_ms"] = 1e3 * sum.inject / frames;
  state.counters["propagate_ms"] = 1e3 * sum.propagate / frames;
  state.counters["shade_ms"] = 1e3 * sum.shade / frames;
  const double frame = (sum.voxelise + sum.inject + sum.propagate + sum.shade) / frames;
  state.counters["frame_ms"] = 1e3 * frame;
  state.counters["fps"] = 1.0 / frame;
  state.counters["grid_MB"] = double(bytes) / 1e6;
}

// One frame of `scene` (update and a 512 x 512 image at one sample per pixel), its stage times
// added to `sum`.
void frame(LpvSolver& solver, const Scene& scene, LpvFrameTimes& sum) {
  Expected<LpvFrameTimes> updated = solver.update(scene);
  if (!updated) std::abort();
  LpvFrameTimes t = *updated;
  const Image image = solver.render(scene, *scene.camera, 512, 512, 1, 0, &t);
  benchmark::DoNotOptimize(image.pixels.data());
  sum.voxelise += t.voxelise;
  sum.inject += t.inject;
  sum.propagate += t.propagate;
  sum.shade += t.shade;
}

void BM_LpvFrame(benchmark::State& state) {
  Scene scene = bunny(int(state.range(2)));
  LpvOptions o;
  o.grid = int(state.range(0));
  o.steps = int(state.range(1));
  Expected<LpvSolver> solver = LpvSolver::build(scene, o);
  if (!solver) std::abort();
  const std::vector<Light> lights = scene.lights;
  const glm::vec3 centre = sceneCentre(scene);
  // The first frame voxelises and traces the camera: not part of the moving-light frames.
  if (!solver->update(scene)) std::abort();
  solver->render(scene, *scene.camera, 512, 512, 1, 0);
  LpvFrameTimes sum;
  int count = 0;
  for (auto _ : state) {
    scene.lights =
        orbitLights(lights, centre, 2.0f * std::numbers::pi_v<float> * float(count++ % 64) / 64.0f);
    frame(*solver, scene, sum);
  }
  report(state, sum, double(count), solver->gridBytes());
}
BENCHMARK(BM_LpvFrame)
    ->ArgNames({"grid", "steps", "lights"})
    ->Args({32, 8, 1})
    ->Args({32, 32, 1})
    ->Args({64, 8, 1})
    ->Args({64, 32, 1})
    ->Args({32, 8, 2})
    ->Args({64, 8, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_LpvBlobsFrame(benchmark::State& state) {
  const SceneAnimation blobs = *builtinAnimation("blobs");
  Expected<Scene> first = blobs(0.0);
  if (!first) std::abort();
  LpvOptions o;
  o.grid = int(state.range(0));
  o.steps = int(state.range(1));
  Expected<LpvSolver> solver = LpvSolver::build(*first, o);
  if (!solver) std::abort();
  LpvFrameTimes sum;
  int count = 0;
  for (auto _ : state) {
    state.PauseTiming();  // remeshing is the animation's, not the method's
    Expected<Scene> scene = blobs(double(count++ % 32) / 32.0);
    if (!scene) std::abort();
    state.ResumeTiming();
    frame(*solver, *scene, sum);
  }
  report(state, sum, double(count), solver->gridBytes());
}
BENCHMARK(BM_LpvBlobsFrame)
    ->ArgNames({"grid", "steps"})
    ->Args({32, 8})
    ->Args({64, 32})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_LpvPropagate(benchmark::State& state) {
  const Scene scene = bunny(1);
  LpvOptions o;
  o.grid = int(state.range(0));
  Expected<LpvSolver> solver = LpvSolver::build(scene, o);
  if (!solver) std::abort();
  if (!solver->update(scene)) std::abort();
  const LpvObject& object = solver->objects()[0];
  const LpvTransfer transfer = lpvTransfer(object.grid, object.cells, object.cell_medium);
  LpvField a = object.injected, b = object.injected, sent;
  const int steps = int(state.range(1));
  for (auto _ : state) {
    for (int s = 0; s < steps; ++s) {
      lpvPropagate(object.grid, transfer, a, b, sent);
      std::swap(a, b);
    }
    benchmark::DoNotOptimize(a.c[0].data());
  }
  state.counters["object_cells"] = double(transfer.cells.size());
}
BENCHMARK(BM_LpvPropagate)
    ->ArgNames({"grid", "steps"})
    ->Args({32, 8})
    ->Args({64, 8})
    ->Args({32, 32})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The injection of emitters and the environment (subsurface/lpv_inject.cpp: 16384 surface points
// x 16 rays by default) on the bunny under a sky whose radiance changes every frame, so that it
// is redone each time (a moving light alone keeps it).
void BM_LpvSurroundings(benchmark::State& state) {
  Scene scene = bunny(1);
  LpvOptions o;
  o.surface_samples = int(state.range(0));
  o.surface_rays = int(state.range(1));
  Expected<LpvSolver> solver = LpvSolver::build(scene, o);
  if (!solver) std::abort();
  LpvFrameTimes sum;
  int count = 0;
  for (auto _ : state) {
    scene.environment = glm::vec3(0.02f + 0.001f * float(count++ % 2));
    frame(*solver, scene, sum);
  }
  report(state, sum, double(count), solver->gridBytes());
}
BENCHMARK(BM_LpvSurroundings)
    ->ArgNames({"points", "rays"})
    ->Args({16384, 16})
    ->Args({65536, 16})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The peer: the dipole through links on the same scene, image and moving light.
void BM_SssFramePeer(benchmark::State& state) {
  Scene scene = bunny(1);
  SssOptions so;
  so.resolution.size = 512;
  so.cache_directory = (std::filesystem::current_path() / "sss-bench-cache").string();
  Expected<SssSolver> solver = SssSolver::build(scene, so);
  if (!solver) std::abort();
  SssViewSettings view;
  view.width = view.height = 512;
  view.spp = 1;
  Expected<SssFrames> frames = SssFrames::create(*solver, *scene.camera, view, false);
  if (!frames) std::abort();
  const glm::vec3 centre = sceneCentre(scene);
  int count = 0;
  for (auto _ : state) {
    const std::vector<Light> lights = orbitLights(
        scene.lights, centre, 2.0f * std::numbers::pi_v<float> * float(count++ % 64) / 64.0f);
    Expected<SssFrame> f = frames->render(lights);
    if (!f) std::abort();
    benchmark::DoNotOptimize(f->image.pixels.data());
  }
}
BENCHMARK(BM_SssFramePeer)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
