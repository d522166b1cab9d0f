// `penumbra render --method sss`: subsurface scattering through hierarchical links (Carr, Hall,
// Hart 2003, sec. 4) on the CPU or the GPU; with --frames N the scene's lights orbit the scene
// once while the links stay, and every frame costs only the three passes (their times are in
// the stats).
#include "penumbra/core/file_util.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/timer.h"
#include "penumbra/io/image_io.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/methods/device.h"
#include "penumbra/methods/render.h"
#include "penumbra/methods/run_context.h"
#include "penumbra/methods/stats_file.h"
#include "penumbra/render/sss_frames.h"
#include "penumbra/subsurface/sss.h"
#include "penumbra/subsurface/sss_cache.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <filesystem>
#include <optional>

namespace penumbra {

namespace {

// The options' checks made before the scene is loaded, in the command's order; the outputs.
Expected<std::vector<std::string>> checkSssOptions(const RenderOptions& options, int frames) {
  Expected<std::vector<std::string>> checked = checkRenderOutputs(options, frames);
  if (!checked) return checked.error();
  for (const auto& [set, name] : {std::pair{options.max_depth.has_value(), "--max-depth"},
                                  std::pair{options.solver.has_value(), "--solver"},
                                  std::pair{options.relight_frames > 0, "--relight-frames"},
                                  std::pair{options.elements.has_value(), "--elements"}}) {
    if (set) {
      return inputError("", name,
                        "does not apply to --method sss (size the atlas with --lightmap-size or "
                        "--texel-density)");
    }
  }
  if (options.device == "hybrid") {
    return inputError("", "--device", "hybrid: --method sss runs on the cpu or the gpu");
  }
  const int width = options.width.value_or(512), height = options.height.value_or(512);
  const int spp = options.spp.value_or(4);
  // Ranges: methods/registry.cpp.
  // The image, its view samples (about 40 bytes each) and the files.
  PENUMBRA_TRY(
      checkMemory(uint64_t(width) * uint64_t(height) * (40 + 40 * uint64_t(spp)),
                  fmt::format("a {}x{} image at {} samples per pixel", width, height, spp)));
  return checked;
}

// The solver's options: the atlas's resolution, the links, the cache and the shadows.
Expected<SssOptions> sssSolverOptions(const RenderOptions& options) {
  SssOptions so;
  if (options.texel_density) {
    so.resolution.texel_density = options.texel_density;
  } else if (options.lightmap_size) {
    so.resolution.size = options.lightmap_size;
  }
  if (options.links && options.links_level >= 0) {
    return inputError("", "--links", "and --links-level exclude each other");
  }
  so.links.links = options.links.value_or(so.links.links);
  so.links.level = options.links_level;
  if (!options.no_cache) so.cache_directory = defaultCacheDirectory();
  so.shadows = !options.no_shadows;
  return so;
}

// Builds the links (or reads them from the cache) with a progress bar, and logs what was built.
Expected<SssSolver> buildSssSolver(const Scene& scene, const SssOptions& so,
                                   const CommonOptions& common) {
  std::optional<Progress> progress;
  Expected<SssSolver> built = SssSolver::build(scene, so, [&](size_t done, size_t total) {
    if (!progress) {
      progress.emplace("subsurface links", uint64_t(total),
                       !common.quiet && Progress::stderrIsTerminal());
    }
    progress->reach(done);
  });
  if (progress) progress->finish();
  if (!built) return built;
  const SssSolver& solver = *built;
  const SssLinks& links = solver.links();
  if (!solver.cacheProblem().empty()) {
    spdlog::warn("the links could not be cached: {}", solver.cacheProblem());
  }
  spdlog::info("{}: {} texels in a {}x{} atlas, {} links each, built in {:.2f} s ({})",
               scene.source, solver.surface().elementCount(), solver.surface().atlas.width,
               solver.surface().atlas.height, links.per_element, solver.buildSeconds(),
               solver.linksFromCache() ? std::string("links from the cache")
                                       : fmt::format("links {:.2f} s", links.seconds));
  return built;
}

// What the frames leave for the stats.
struct SssFrameTotals {
  nlohmann::json frame_stats = nlohmann::json::array();
  double frame_sum = 0.0;
  uint64_t rays = 0;
};

// Renders and writes each frame, the lights orbiting the scene when there are several.
Status renderSssFrames(const RenderOptions& options, const std::vector<std::string>& outputs,
                       int frames, const Scene& scene, SssFrames& renderer,
                       SssFrameTotals& totals) {
  const glm::vec3 centre = sceneCentre(scene);
  for (int f = 0; f < frames; ++f) {
    throwIfInterrupted();  // a caller's stop request ends the sequence between two frames
    const std::vector<Light> lights =
        frames > 1
            ? orbitLights(scene.lights, centre, 2.0f * 3.14159265f * float(f) / float(frames))
            : scene.lights;
    Expected<SssFrame> frame = renderer.render(lights, &totals.rays);
    if (!frame) return frame.error();
    const Image& image = frame->image;
    const double pass1 = frame->times.irradiance, pass2 = frame->times.gather,
                 pass3 = frame->times.image;
    totals.frame_sum += pass1 + pass2 + pass3;
    totals.frame_stats.push_back({{"pass1_seconds", pass1},
                                  {"pass2_seconds", pass2},
                                  {"pass3_seconds", pass3},
                                  {"seconds", pass1 + pass2 + pass3}});
    emitImage(image);
    for (const std::string& out : outputs) {
      PENUMBRA_TRY(
          writeMethodImage(frames > 1 ? sequenceFrameName(out, f) : out, image, options.tonemap));
    }
  }
  return {};
}

// The render's stats (--stats).
nlohmann::json sssStats(const RenderOptions& options, const DeviceChoice& device,
                        const Scene& scene, const Timer& total_timer, const SssOptions& so,
                        const SssSolver& solver, const SssFrames& renderer, int frames,
                        const SssFrameTotals& totals) {
  const SssLinks& links = solver.links();
  return {{"method", "sss"},
          {"device", device.name()},
          {"scene", scene.source},
          {"seconds", total_timer.seconds()},
          {"build_seconds", solver.buildSeconds()},
          {"links_seconds", links.seconds},
          {"links_cached", solver.linksFromCache()},
          {"view_seconds", renderer.viewSeconds()},
          {"elements", solver.surface().elementCount()},
          {"atlas_width", solver.surface().atlas.width},
          {"atlas_height", solver.surface().atlas.height},
          {"texel_density", solver.surface().atlas.texel_density},
          {"links", links.per_element},
          {"adaptive", so.links.level < 0},
          {"shadows", so.shadows},
          {"threads", threadCount()},
          {"width", options.width.value_or(512)},
          {"height", options.height.value_or(512)},
          {"spp", options.spp.value_or(4)},
          {"frames", totals.frame_stats},
          {"frame_seconds", totals.frame_sum / frames},
          {"frames_per_second", frames / totals.frame_sum},
          {"rays", totals.rays}};
}

}  // namespace

Status renderSss(const RenderOptions& options, const CommonOptions& common) {
  const int frames = options.frames > 1 ? options.frames : 1;
  Expected<std::vector<std::string>> checked = checkSssOptions(options, frames);
  if (!checked) return checked.error();
  const std::vector<std::string>& outputs = *checked;

  const Timer total_timer;
  const Scene* const scene = &runScene();
  for (const std::string& w : scene->warnings) spdlog::warn("{}", w);
  for (const std::string& w : diffuseStandInWarnings(*scene, "sss")) spdlog::warn("{}", w);
  Expected<SssOptions> so = sssSolverOptions(options);
  if (!so) return so.error();
  // A dry run builds the atlas as the run would (not the links).
  if (common.dry_run) return SssSolver::check(*scene, *so);

  Expected<DeviceChoice> device = chooseDevice(options.device);
  if (!device) return device.error();
  Expected<SssSolver> built = buildSssSolver(*scene, *so, common);
  if (!built) return built.error();
  const SssSolver& solver = *built;

  const Camera camera = scene->camera ? *scene->camera : defaultCamera(*scene);
  SssViewSettings view;
  view.width = options.width.value_or(512);
  view.height = options.height.value_or(512);
  view.spp = options.spp.value_or(4);
  view.seed = options.seed.value_or(0);
  Expected<SssFrames> renderer =
      SssFrames::create(solver, camera, view, device->device == Device::kGpu);
  if (!renderer) return renderer.error();

  SssFrameTotals totals;
  PENUMBRA_TRY(renderSssFrames(options, outputs, frames, *scene, *renderer, totals));
  spdlog::info("{} frame(s), {:.1f} ms each ({:.1f} frames per second); wrote {}", frames,
               1e3 * totals.frame_sum / frames, frames / totals.frame_sum,
               fmt::join(outputs, ", "));
  if (wantsStats(options.stats)) {
    PENUMBRA_TRY(emitStats(options.stats, sssStats(options, *device, *scene, total_timer, *so,
                                                   solver, *renderer, frames, totals)));
  }
  return {};
}

}  // namespace penumbra
