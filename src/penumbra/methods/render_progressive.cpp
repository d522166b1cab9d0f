// `penumbra render --method progressive|stochastic`: the radiosity methods whose solution is the
// lightmap itself, progressive refinement radiosity (Wallner, sec. 2-3) and stochastic radiosity
// (Barsi and Jakab), viewed from the camera through the lightmap with bilinear filtering, as a
// lightmapped scene is displayed.
#include "penumbra/cluster/communicator.h"
#include "penumbra/core/file_util.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/timer.h"
#include "penumbra/io/image_io.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/methods/device.h"
#include "penumbra/methods/illuminance_output.h"
#include "penumbra/methods/progressive_run.h"
#include "penumbra/methods/render.h"
#include "penumbra/methods/run_context.h"
#include "penumbra/methods/stats_file.h"
#include "penumbra/methods/stochastic_run.h"
#include "penumbra/radiosity/progressive.h"
#include "penumbra/render/lightmap_view.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <glm/geometric.hpp>

#include <cmath>
#include <filesystem>

namespace penumbra {

namespace {

// The outputs and the options that do not apply to the lightmap methods, checked before
// anything is loaded.
Status checkLightmapRenderOptions(const RenderOptions& options,
                                  const std::vector<std::string>& outputs, bool stochastic) {
  for (const std::string& out : outputs) {
    if (!isSupportedImageExtension(out)) {
      return inputError(out, "",
                        fmt::format("unsupported image format '{}' (use .exr, .hdr, .pfm or .png)",
                                    extensionOf(out)));
    }
    PENUMBRA_TRY(checkOutputPath(out));
  }
  if (!options.stats.empty()) PENUMBRA_TRY(checkOutputPath(options.stats));
  if (options.max_depth) return inputError("", "--max-depth", "applies to --method pathtrace only");
  if (options.solver) return inputError("", "--solver", "applies to --method matrix only");
  if (options.relight_frames > 0) {
    return inputError("", "--relight-frames", "applies to --method matrix only");
  }
  if (!stochastic && (options.time_limit || options.shooters != 1)) {
    return inputError("", options.time_limit ? "--time-limit" : "--shooters",
                      "applies to --method stochastic only");
  }
  if (stochastic && (options.adaptive || options.receiver_level)) {
    return inputError("", options.adaptive ? "--adaptive" : "--receiver-level",
                      "applies to --method progressive only");
  }
  return {};
}

// Lux: the lightmap's radiance gathered over each point's hemisphere.
Expected<std::optional<IlluminanceReport>> lightmapIlluminance(
    const Scene& scene, const RadiositySurface& surface, const Image& lightmap,
    const LightmapDetail* detail, const Camera& camera,
    const std::optional<IlluminanceRequest>& lux) {
  if (!lux) return std::optional<IlluminanceReport>();
  const LightmapLookup lookup(surface.flat.positions, surface.flat.triangles, surface.atlas,
                              lightmap, detail);
  Expected<IlluminanceReport> r = illuminanceReport(
      scene, surface.engine, surface.flat, camera, *lux, [&](const Ray& ray, const Hit& hit, Rng&) {
        return lookup.radiance(ray.dir, hit.triangle, hit.u, hit.v);
      });
  if (!r) return r.error();
  return std::optional<IlluminanceReport>(std::move(*r));
}

// The summary line.
void logLightmapSummary(const std::optional<ProgressiveRun>& progressive,
                        const std::optional<StochasticRun>& stoch,
                        const std::vector<std::string>& outputs) {
  if (stoch) {
    spdlog::info("{} iterations, estimated error {:.3g}, {:.2f} s; wrote {}",
                 stoch->stats.total_iterations, stoch->stats.error, stoch->stats.seconds,
                 fmt::join(outputs, ", "));
  } else {
    spdlog::info("{} iterations, {:.3g} of the emitted power unshot, {:.2f} s; wrote {}",
                 progressive->stats.total_iterations, progressive->stats.unshot_fraction,
                 progressive->stats.seconds, fmt::join(outputs, ", "));
  }
}

// The stats: the view's settings and times, the solve's stats and the lux.
Status writeLightmapStats(const RenderOptions& options, const Scene& scene,
                          const Timer& total_timer, double view_seconds, int width, int height,
                          int spp, const std::optional<ProgressiveRun>& progressive,
                          const std::optional<StochasticRun>& stoch, double tolerance,
                          const nlohmann::json& lux_stats) {
  if (!wantsStats(options.stats)) return {};
  nlohmann::json j = {{"method", options.method},
                      {"scene", scene.source},
                      {"seconds", total_timer.seconds()},
                      {"view_seconds", view_seconds},
                      {"threads", threadCount()},
                      {"width", width},
                      {"height", height},
                      {"spp", spp}};
  j.update(stoch ? stochasticStatsJson(*stoch) : progressiveStatsJson(*progressive, tolerance));
  j.update(lux_stats);
  PENUMBRA_TRY(emitStats(options.stats, j));
  return {};
}

}  // namespace

Status renderLightmapRadiosity(const RenderOptions& options, const CommonOptions& common,
                               bool* interrupted) {
  // Over several processes (mpirun, progressive only): every rank loads and checks, then they
  // agree to start; rank 0 draws and writes.
  Communicator& comm = currentCommunicator();
  ReadyGate gate(comm);
  const bool stochastic = options.method == "stochastic";
  std::vector<std::string> outputs = options.outputs;
  const std::string stem = sceneStem(options.scene);
  if (outputs.empty() && defaultsOutputs()) outputs.push_back(stem + ".png");
  PENUMBRA_TRY(checkLightmapRenderOptions(options, outputs, stochastic));
  const std::string checkpoint =
      !options.checkpoint.empty() ? options.checkpoint
      : outputs.empty()
          ? stem + ".checkpoint"
          : std::filesystem::path(outputs.front()).replace_extension(".checkpoint").string();
  ProgressiveRunOptions ro = progressiveRunOptions(options);
  StochasticRunOptions so = stochasticRunOptions(options);
  ro.checkpoint = so.checkpoint = checkpoint;
  PENUMBRA_TRY(stochastic ? checkStochasticRunOptions(so) : checkProgressiveRunOptions(ro));
  const int width = options.width.value_or(512), height = options.height.value_or(512);
  const int spp = options.spp.value_or(4);
  // Ranges: methods/registry.cpp.
  std::optional<IlluminanceRequest> lux;
  if (wantsIlluminance(options)) {
    Expected<IlluminanceRequest> r = illuminanceRequest(options, width, height);
    if (!r) return r.error();
    lux = *r;
  }
  PENUMBRA_TRY(checkMemory(uint64_t(width) * uint64_t(height) * 40,
                           fmt::format("a {}x{} image", width, height)));

  const Timer total_timer;
  const Scene* const scene = &runScene();
  for (const std::string& w : scene->warnings) spdlog::warn("{}", w);
  for (const std::string& w : diffuseStandInWarnings(*scene, options.method)) spdlog::warn("{}", w);
  PENUMBRA_TRY(prepareIlluminance(lux, options, *scene, width, height));
  // The solution: a lightmap over the surface's atlas, the stats and a summary line.
  std::optional<ProgressiveRun> progressive;
  std::optional<StochasticRun> stoch;
  if (stochastic) {
    Expected<StochasticRun> run = runStochastic(*scene, so, common);
    if (!run) return run.error();
    if (run->dry_run) return {};
    stoch.emplace(std::move(*run));
  } else {
    Expected<ProgressiveRun> run = runProgressive(*scene, ro, common, &gate);
    if (!run) return run.error();
    if (run->dry_run) return {};
    progressive.emplace(std::move(*run));
  }
  if (!comm.root()) {
    if (progressive->interrupted) *interrupted = true;
    return {};  // rank 0 draws and writes
  }
  const RadiositySurface& surface =
      stochastic ? stoch->solver->surface() : progressive->solver->surface();
  if (stochastic ? stoch->interrupted : progressive->interrupted) *interrupted = true;

  const Timer view_timer;
  const Camera camera = scene->camera ? *scene->camera : defaultCamera(*scene);
  LightmapViewSettings view;
  view.width = width;
  view.height = height;
  view.spp = spp;
  view.seed = options.seed.value_or(0);
  const Image& lightmap = stochastic ? *stoch->lightmap : *progressive->lightmap;
  const std::shared_ptr<const LightmapDetail> detail = surface.lightmapDetail();
  const Image image = renderLightmapView(surface.flat.positions, surface.flat.triangles,
                                         surface.atlas, lightmap, camera, view, detail.get());
  const double view_seconds = view_timer.seconds();
  // Lux: the lightmap's radiance gathered over each point's hemisphere.
  Expected<std::optional<IlluminanceReport>> report =
      lightmapIlluminance(*scene, surface, lightmap, detail.get(), camera, lux);
  if (!report) return report.error();
  nlohmann::json lux_stats = nlohmann::json::object();
  emitImage(renderedValues(options, image, *report ? &**report : nullptr));
  PENUMBRA_TRY(
      writeRenderOutputs(options, outputs, image, *report ? &**report : nullptr, &lux_stats));
  logLightmapSummary(progressive, stoch, outputs);

  PENUMBRA_TRY(writeLightmapStats(options, *scene, total_timer, view_seconds, width, height, spp,
                                  progressive, stoch, ro.tolerance, lux_stats));
  return {};
}

}  // namespace penumbra
