// `penumbra render --method lpv`: subsurface light propagation volumes (Børlum et al. 2011), the
// propagation on the CPU or the GPU (`--device`); with --frames N an animated built-in scene
// (`blobs`) moves and remeshes, any other scene's lights orbit it once, and every frame runs the
// whole method again (voxelisation, injection, propagation, shading: no precomputation), with each
// stage's milliseconds in the stats, as the paper's Table 1.
#include "penumbra/core/file_util.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/io/image_io.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/methods/device.h"
#include "penumbra/methods/render.h"
#include "penumbra/methods/run_context.h"
#include "penumbra/methods/stats_file.h"
#include "penumbra/scene/animation.h"
#include "penumbra/subsurface/lpv.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <numbers>
#include <optional>

namespace penumbra {

Status renderLpv(const RenderOptions& options, const CommonOptions& common) {
  const int frames = options.frames > 1 ? options.frames : 1;
  Expected<std::vector<std::string>> checked = checkRenderOutputs(options, frames);
  if (!checked) return checked.error();
  const std::vector<std::string>& outputs = *checked;
  if (options.device == "hybrid") {
    return inputError("", "--device", "hybrid: --method lpv runs on the cpu or the gpu");
  }
  const int width = options.width.value_or(512), height = options.height.value_or(512);
  const int spp = options.spp.value_or(4);
  // Ranges: methods/registry.cpp.
  PENUMBRA_TRY(checkMemory(uint64_t(width) * uint64_t(height) * 16,
                           fmt::format("a {}x{} image", width, height)));
  LpvOptions lo;
  lo.grid = options.grid.value_or(lo.grid);
  lo.steps = options.steps.value_or(lo.steps);
  lo.skip_steps = options.skip_steps.value_or(lo.skip_steps);
  lo.rsm_resolution = options.rsm_resolution.value_or(lo.rsm_resolution);
  lo.surface_samples = options.surface_samples.value_or(lo.surface_samples);
  lo.surface_rays = options.surface_rays.value_or(lo.surface_rays);

  const Timer total_timer;
  Scene scene_copy = runScene();  // the instances placed and the lights added below
  Scene* const scene = &scene_copy;
  for (const std::string& w : scene->warnings) spdlog::warn("{}", w);
  for (const std::string& w : diffuseStandInWarnings(*scene, "lpv")) spdlog::warn("{}", w);
  // Declared before the solver, so that its GPU objects go before the context does.
  std::optional<DeviceChoice> device;
  Expected<LpvSolver> built = LpvSolver::build(*scene, lo);
  if (!built) return built.error();
  if (common.dry_run) return {};
  LpvSolver& solver = *built;
  // The propagation on the chosen device; the injection and the view stay on the CPU.
  Expected<DeviceChoice> chosen = chooseDevice(options.device);
  if (!chosen) return chosen.error();
  device = std::move(*chosen);
  if (device->device == Device::kGpu) PENUMBRA_TRY(solver.useGpu());
  const Camera camera = scene->camera ? *scene->camera : defaultCamera(*scene);
  const glm::vec3 centre = sceneCentre(*scene);
  const std::vector<Light> lights = scene->lights;
  // An animated built-in scene moves its meshes (and changes their topology) from frame to
  // frame; any other scene's lights orbit it.
  const std::optional<SceneAnimation> animation = builtinAnimation(options.scene);
  nlohmann::json frame_stats = nlohmann::json::array();
  double frame_sum = 0.0;
  for (int f = 0; f < frames; ++f) {
    throwIfInterrupted();  // a caller's stop request ends the sequence between two frames
    if (frames > 1 && animation) {
      Expected<Scene> at = (*animation)(double(f) / double(frames));
      if (!at) return at.error();
      *scene = std::move(*at);
    } else if (frames > 1) {
      scene->lights =
          orbitLights(lights, centre, 2.0f * std::numbers::pi_v<float> * float(f) / float(frames));
    }
    Expected<LpvFrameTimes> updated = solver.update(*scene);
    if (!updated) return updated.error();
    LpvFrameTimes t = *updated;
    const Image image =
        solver.render(*scene, camera, width, height, spp, options.seed.value_or(0), &t);
    const double seconds = t.voxelise + t.inject + t.propagate + t.shade;
    frame_sum += seconds;
    size_t triangles = 0;
    for (const Mesh& m : scene->meshes) triangles += m.triangles.size();
    frame_stats.push_back({{"triangles", triangles},
                           {"voxelise_ms", 1e3 * t.voxelise},
                           {"inject_ms", 1e3 * t.inject},
                           {"propagate_ms", 1e3 * t.propagate},
                           {"shade_ms", 1e3 * t.shade},
                           {"ms", 1e3 * seconds},
                           {"rsm_texels", t.rsm_texels}});
    emitImage(image);
    for (const std::string& out : outputs) {
      PENUMBRA_TRY(
          writeMethodImage(frames > 1 ? sequenceFrameName(out, f) : out, image, options.tonemap));
    }
  }
  const LpvObject& first = solver.objects().front();
  spdlog::info(
      "{}: {} translucent object(s), {}x{}x{} cells, {} steps; {} frame(s), {:.1f} ms "
      "each; wrote {}",
      scene->source, solver.objects().size(), first.grid.size.x, first.grid.size.y,
      first.grid.size.z, lo.steps, frames, 1e3 * frame_sum / frames, fmt::join(outputs, ", "));
  if (wantsStats(options.stats)) {
    nlohmann::json objects = nlohmann::json::array();
    for (const LpvObject& o : solver.objects()) {
      size_t inside = 0, boundary = 0;
      for (LpvCell c : o.cells) {
        inside += c == LpvCell::kInside;
        boundary += c == LpvCell::kBoundary;
      }
      objects.push_back({{"mesh", scene->meshes[o.mesh].name},
                         {"grid", {o.grid.size.x, o.grid.size.y, o.grid.size.z}},
                         {"cell_m", o.grid.cell},
                         {"inside_cells", inside},
                         {"boundary_cells", boundary}});
    }
    nlohmann::json j = {{"method", "lpv"},
                        {"device", device->name()},
                        {"scene", scene->source},
                        {"seconds", total_timer.seconds()},
                        {"grid", lo.grid},
                        {"steps", lo.steps},
                        {"skip_steps", lo.skip_steps},
                        {"rsm_resolution", lo.rsm_resolution},
                        {"surface_samples", lo.surface_samples},
                        {"surface_rays", lo.surface_rays},
                        {"grid_bytes", solver.gridBytes()},
                        {"objects", objects},
                        {"threads", threadCount()},
                        {"width", width},
                        {"height", height},
                        {"spp", spp},
                        {"frames", frame_stats},
                        {"frame_ms", 1e3 * frame_sum / frames},
                        {"frames_per_second", frames / frame_sum}};
    PENUMBRA_TRY(emitStats(options.stats, j));
  }
  return {};
}

}  // namespace penumbra
