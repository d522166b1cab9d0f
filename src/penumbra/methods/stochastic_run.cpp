#include "penumbra/methods/stochastic_run.h"

#include "penumbra/methods/device.h"
#include "penumbra/methods/progressive_run.h"

#include "penumbra/core/file_util.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/timer.h"
#include "penumbra/radiosity/radiosity_solvers.h"
#include "penumbra/radiosity/stochastic_checkpoint.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <optional>

namespace penumbra {

namespace {

// Bytes per element at the peak: the atlas and hierarchy (about 180, as progressive radiosity
// counts them), the surface's per-element data (4 x 24), E', the iterate, the next iterate and
// the two sums and the first shots' part (6 x 24), the element's pieces (about 2 x 200), the
// level sums (about 11) and the local operator's pairs (8 bytes each, where surfaces meet or
// curve: at most about 60 per texel within 4 texel sizes; 4.4 measured on the Cornell box, 14.7
// in the atrium). The first shots' progressive solver (about 150 more) is gone by then.
constexpr uint64_t kBytesPerElement = 1400;

// The solve: Ctrl-C stops it between two iterations and writes a checkpoint; the lightmap
// into `run`.
Status solveStochastic(StochasticRun& run, const Scene& scene, const StochasticRunOptions& options,
                       const CommonOptions& common, const StochasticOptions& so,
                       StochasticSolver& solver) {
  StochasticRadiosity& sr = *run.solver;
  // From here Ctrl-C stops between two iterations and writes a checkpoint. The line below is
  // printed once it does (scripts may wait for it before sending SIGINT).
  const InterruptScope interrupt;
  spdlog::info(
      "{}: {} lightmap texels in a {}x{} atlas ({:.1f} texels/m), {} first shots ({:.2f} s), "
      "burn-in {} iterations{}",
      scene.source, sr.elementCount(), sr.atlas().width, sr.atlas().height,
      sr.atlas().texel_density, sr.firstShots(), sr.firstShotSeconds(), sr.burnIn(),
      solver.device() == SolverDevice::kGpu ? ", on the GPU" : "");

  // Progress: iterations against the cap (or the time against the limit), with the iteration
  // and the running error estimate.
  const bool by_time = options.time_limit > 0.0;
  Progress progress("iterating", by_time ? 1000 : uint64_t(std::max(so.iterations, 1)),
                    !common.quiet && Progress::stderrIsTerminal());
  const Timer solve_timer;
  Status device_error;
  const auto after = [&](const StochasticIteration& it) {
    double error = 1.0;
    if (solver.averaged() >= 2) {
      Expected<double> e = solver.errorEstimate();
      if (e) {
        error = *e;
      } else if (device_error) {
        device_error = e.error();
      }
    }
    run.history.push_back(error);
    progress.setNote(fmt::format("iteration {}, error ~{:.3g}", it.iteration, error));
    progress.reach(
        by_time ? uint64_t(std::min(solve_timer.seconds() / options.time_limit, 1.0) * 1000.0)
                : uint64_t(it.iteration));
  };
  const auto stop = [&] { return InterruptScope::requested() || !device_error; };
  Expected<StochasticStats> st = solver.solve(after, stop);
  if (!st) return st.error();
  PENUMBRA_TRY(device_error);
  run.stats = *st;
  PENUMBRA_TRY(solver.sync());  // the state into the CPU object: checkpoints and the lightmap
  progress.finish();
  if (run.stats.interrupted) {
    run.interrupted = true;
    PENUMBRA_TRY(writeStochasticCheckpoint(options.checkpoint, scene, sr));
    spdlog::warn(
        "interrupted after {} iterations (estimated error {:.3g}): checkpoint written to {}; "
        "continue with --resume {}",
        run.stats.total_iterations, run.stats.error, options.checkpoint, options.checkpoint);
  } else if (!options.resume.empty() && !options.keep_checkpoint) {
    if (OutputTransaction* t = OutputTransaction::current()) t->removeOnCommit(options.resume);
  }
  if (sr.averaged() == 0) {
    spdlog::warn("stopped within the burn-in ({} of {} iterations): the estimate is one iterate",
                 sr.iterations(), sr.burnIn());
  }
  run.lightmap = sr.radianceImage();
  return {};
}

}  // namespace

Status checkStochasticRunOptions(const StochasticRunOptions& o) {
  if (o.texel_density && !(*o.texel_density > 0.0 && std::isfinite(*o.texel_density))) {
    return inputError("", "--texel-density", "must be a positive number of texels per metre");
  }
  if (!(o.time_limit >= 0.0 && std::isfinite(o.time_limit))) {
    return inputError("", "--time-limit", "must be a number of seconds >= 0");
  }
  if (o.shooters < 1 || o.shooters > 4096) {
    return inputError("", "--shooters", "must be in [1, 4096]");
  }
  if (o.first_shots < 0 || o.first_shots > 4096) {
    return inputError("", "--first-shots", "must be in [0, 4096]");
  }
  if (!o.resume.empty() && o.lightmap_size) {
    return inputError("", "--resume",
                      "the checkpoint fixes the lightmap: leave out --lightmap-size");
  }
  if (!o.checkpoint.empty()) PENUMBRA_TRY(checkOutputPath(o.checkpoint));
  return {};
}

namespace {

// The options a stochastic checkpoint fixes (the lightmap and the random numbers), against those
// the caller gave.
Status checkResumedStochastic(const Scene& scene, const StochasticRunOptions& o,
                              const StochasticCheckpointInfo& info) {
  const auto check = [&](const char* name, const std::string& fixed, const std::string& asked) {
    return checkResumedOption(o.given, o.resume, name, fixed, asked);
  };
  if (o.texel_density) {
    if (std::abs(*o.texel_density / info.texel_density - 1.0) > 1e-9) {
      PENUMBRA_TRY(check("texel-density", fmt::format("{:g}", info.texel_density),
                         fmt::format("{:g}", *o.texel_density)));
    }
  } else if (std::find(o.given.begin(), o.given.end(), "elements") != o.given.end()) {
    LightmapResolution r;
    r.elements = o.elements;
    Expected<ChartAtlasOptions> atlas = lightmapAtlasOptions(scene, r);
    if (atlas && std::abs(atlas->texel_density / info.texel_density - 1.0) > 1e-9) {
      return inputError(o.resume, "",
                        fmt::format("was written with {:g} texels per metre; --elements {} gives "
                                    "{:g}",
                                    info.texel_density, o.elements, atlas->texel_density));
    }
  }
  PENUMBRA_TRY(check("seed", std::to_string(info.seed), std::to_string(o.seed)));
  PENUMBRA_TRY(check("shooters", std::to_string(info.shooters), std::to_string(o.shooters)));
  return check("first-shots", std::to_string(info.first_shots), std::to_string(o.first_shots));
}

}  // namespace

Expected<StochasticRun> runStochastic(const Scene& scene, const StochasticRunOptions& options,
                                      const CommonOptions& common) {
  StochasticRun run;
  if (options.device == "hybrid") {
    return inputError("", "--device", "hybrid applies to the Ray Engine (trace, pathtrace)");
  }
  StochasticOptions so;
  so.iterations = options.iterations;
  so.time_limit = options.time_limit;
  so.shooters = options.shooters;
  so.first_shots = options.first_shots;
  so.seed = options.seed;
  so.shading_normals = options.shading_normals;
  std::optional<StochasticCheckpointInfo> info;
  LightmapResolution resolution;
  resolution.texel_density = options.texel_density;
  resolution.asset_uvs = options.asset_uvs;
  resolution.size = options.lightmap_size;
  resolution.elements = options.elements;
  if (!options.resume.empty()) {
    Expected<StochasticCheckpointInfo> i = readStochasticCheckpointInfo(options.resume);
    if (!i) return i.error();
    info = *i;
    // The checkpoint fixes the lightmap and the random numbers (so that the resumed run
    // continues exactly as the interrupted one would have).
    so.atlas.texel_density = info->texel_density;
    so.atlas.asset_uvs = options.asset_uvs;
    so.seed = info->seed;
    so.shooters = info->shooters;
    so.burn_in = info->burn_in;
    so.first_shots = info->first_shots;
    PENUMBRA_TRY(checkResumedStochastic(scene, options, *info));
  } else {
    Expected<ChartAtlasOptions> atlas = lightmapAtlasOptions(scene, resolution);
    if (!atlas) return atlas.error();
    so.atlas = *atlas;
  }
  PENUMBRA_TRY(checkLightmapPlan(scene, resolution,
                                 info ? std::optional<uint64_t>(info->elements) : std::nullopt,
                                 "stochastic radiosity", kBytesPerElement));
  Expected<DeviceChoice> device = chooseDevice(options.device);
  if (!device) return device.error();
  run.device = device->name();
  // A dry run checks what the run would: the lightmap is built (a density that leaves a chart
  // without a texel is refused) and a checkpoint is checked against it (another scene's is
  // refused); the first shots and the iterations are left out.
  if (common.dry_run) {
    Expected<RadiositySurface> surface =
        RadiositySurface::build(scene, so.atlas, so.shading_normals);
    if (!surface) {
      if (info && surface.error().file.empty()) {
        return inputError(options.resume, "",
                          fmt::format("its lightmap ({} texels per metre) cannot be built: {}",
                                      info->texel_density, surface.error().message));
      }
      return surface.error();
    }
    if (info) {
      PENUMBRA_TRY(checkStochasticCheckpoint(options.resume, scene, *surface, so.shading_normals));
    }
    run.dry_run = true;
    return run;
  }

  const Timer build_timer;
  Expected<StochasticRadiosity> built = StochasticRadiosity::build(scene, so);
  if (!built) {
    if (info && built.error().file.empty()) {
      return inputError(options.resume, "",
                        fmt::format("its lightmap ({} texels per metre) cannot be built: {}",
                                    info->texel_density, built.error().message));
    }
    return built.error();
  }
  run.solver.emplace(std::move(*built));
  StochasticRadiosity& sr = *run.solver;
  if (info) {
    PENUMBRA_TRY(resumeStochasticCheckpoint(options.resume, scene, sr));
    run.resumed_iterations = sr.iterations();
    spdlog::info("{}: resumed after {} iterations, estimated error {:.3g}", options.resume,
                 sr.iterations(), sr.errorEstimate());
  }
  // On the GPU the iterate and the average live on the device from here
  // (radiosity/stochastic_gl.h); the CPU solver takes the state back for checkpoints and the
  // lightmap.
  Expected<std::unique_ptr<StochasticSolver>> solver = StochasticSolver::create(
      sr, device->device == Device::kGpu ? SolverDevice::kGpu : SolverDevice::kCpu);
  if (!solver) return solver.error();
  run.build_seconds = build_timer.seconds();
  PENUMBRA_TRY(solveStochastic(run, scene, options, common, so, **solver));
  return run;
}

nlohmann::json stochasticStatsJson(const StochasticRun& run) {
  const StochasticRadiosity& sr = *run.solver;
  return {{"device", run.device},
          {"build_seconds", run.build_seconds},
          {"solve_seconds", run.stats.seconds},
          {"elements", sr.elementCount()},
          {"atlas_width", sr.atlas().width},
          {"atlas_height", sr.atlas().height},
          {"texel_density", sr.atlas().texel_density},
          {"iterations", run.stats.total_iterations},
          {"resumed_iterations", run.resumed_iterations},
          {"burn_in", sr.burnIn()},
          {"averaged_iterations", sr.averaged()},
          {"shooters_per_iteration", sr.options().shooters},
          {"first_shots", sr.firstShots()},
          {"first_shot_seconds", sr.firstShotSeconds()},
          {"local_pairs", sr.local().size()},
          {"seed", sr.options().seed},
          {"error_estimate", run.stats.error},
          {"interrupted", run.interrupted},
          {"timed_out", run.stats.timed_out},
          {"history", run.history},
          {"rays", run.stats.rays}};
}

}  // namespace penumbra
