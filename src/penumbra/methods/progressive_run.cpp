#include "penumbra/methods/progressive_run.h"

#include "penumbra/cluster/communicator.h"
#include "penumbra/core/file_util.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/timer.h"
#include "penumbra/methods/device.h"
#include "penumbra/methods/stats_file.h"
#include "penumbra/radiosity/progressive_checkpoint.h"
#include "penumbra/radiosity/progressive_gl.h"
#include "penumbra/radiosity/radiosity_solvers.h"
#include "penumbra/radiosity/radiosity_surface.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>

namespace penumbra {

namespace {

// Bytes per element a run needs at its peak: the solver keeps B, dB, reflectance, emission and
// shading normal (5 x 24) and an iteration's incident irradiance (24); the chart atlas about 70
// per element and 21 per texel, the hierarchy about 90; a shooter's clusters and pieces come on
// top. Measured with progressive_bench: 347-401 bytes per element from 150,000 elements up, 693
// at 11,000 (docs/performance.md); 700 leaves a margin.
constexpr uint64_t kBytesPerElement = 700;

// A number as a user writes it: 0.05, 16, 1e-05.
std::string written(double v) {
  return fmt::format("{:g}", v);
}

// The options a progressive checkpoint fixes, against those the caller gave.
Status checkResumedProgressive(const Scene& scene, const ProgressiveRunOptions& o,
                               const ProgressiveCheckpointInfo& info) {
  const auto check = [&](const char* name, const std::string& fixed, const std::string& asked) {
    return checkResumedOption(o.given, o.resume, name, fixed, asked);
  };
  if (o.texel_density) {
    if (std::abs(*o.texel_density / info.texel_density - 1.0) > 1e-9) {
      PENUMBRA_TRY(check("texel-density", written(info.texel_density), written(*o.texel_density)));
    }
  } else if (std::find(o.given.begin(), o.given.end(), "elements") != o.given.end()) {
    const double density = progressiveTexelDensity(scene, o.elements);
    if (std::abs(density / info.texel_density - 1.0) > 1e-9) {
      return inputError(o.resume, "",
                        fmt::format("was written with {} texels per metre; --elements {} gives {}",
                                    written(info.texel_density), o.elements, written(density)));
    }
  }
  const int points =
      info.shooter_top_points > 0 ? info.shooter_top_points : info.shooter_min_points;
  PENUMBRA_TRY(check("shooter-points", std::to_string(points), std::to_string(o.shooter_points)));
  PENUMBRA_TRY(check("adaptive", info.adaptive ? "on" : "off", o.adaptive ? "on" : "off"));
  if (o.receiver_level >= 0) {
    PENUMBRA_TRY(check("receiver-level", std::to_string(info.receiver_level),
                       std::to_string(o.receiver_level)));
  }
  const SubdivisionOptions& f = info.subdivision;
  const SubdivisionOptions& a = o.subdivision;
  PENUMBRA_TRY(check("boundary", fmt::format("{:g},{:g}", f.boundary_low, f.boundary_high),
                     fmt::format("{:g},{:g}", a.boundary_low, a.boundary_high)));
  PENUMBRA_TRY(
      check("finest-level", std::to_string(f.finest_level), std::to_string(a.finest_level)));
  return check("min-share", written(f.min_share), written(a.min_share));
}

// The solver's options from the command's, fixed by the checkpoint when resuming (read into
// `info`), and the lightmap's size checked against the memory.
Status prepareProgressive(const Scene& scene, const ProgressiveRunOptions& options,
                          ProgressiveOptions& po, std::optional<ProgressiveCheckpointInfo>& info) {
  po.max_iterations = options.iterations;
  po.convergence = options.tolerance;
  po.shooter_top_points = options.shooter_points;
  po.shooter_min_points = options.shooter_points;  // the flat scheme's (the GPU's)
  po.penumbra_rays = options.penumbra_rays;
  po.shading_normals = options.shading_normals;
  po.adaptive = options.adaptive;
  po.receiver_level = options.receiver_level;
  po.subdivision = options.subdivision;
  if (!options.resume.empty()) {
    Expected<ProgressiveCheckpointInfo> i = readProgressiveCheckpointInfo(options.resume);
    if (!i) return i.error();
    info = *i;
    po.atlas.texel_density = info->texel_density;
    // The checkpoint fixes the substructuring too (so that the resumed run shoots exactly as
    // the interrupted one would have).
    po.shooter_level = info->shooter_level;
    po.shooter_top_points = info->shooter_top_points;
    po.shooter_min_points = info->shooter_min_points;
    po.receiver_level = info->receiver_level;
    po.adaptive = info->adaptive != 0;
    po.subdivision = info->subdivision;
    PENUMBRA_TRY(checkResumedProgressive(scene, options, *info));
  } else if (options.texel_density) {
    po.atlas.texel_density = *options.texel_density;
  } else if (options.lightmap_size) {
    po.atlas.texel_density = 0.0;
    po.atlas.resolution = *options.lightmap_size;
  } else {
    // The density that gives about `elements` occupied texels: density^2 * the faces' area (a
    // two-sided surface counts twice).
    po.atlas.texel_density = progressiveTexelDensity(scene, options.elements);
    if (!(po.atlas.texel_density > 0.0)) {
      return inputError(scene.source, "", "the scene has no surface area");
    }
  }
  po.atlas.asset_uvs = options.asset_uvs;
  LightmapResolution resolution;
  resolution.texel_density = options.texel_density;
  resolution.size = options.lightmap_size;
  resolution.elements = options.elements;
  PENUMBRA_TRY(checkLightmapPlan(scene, resolution,
                                 info ? std::optional<uint64_t>(info->elements) : std::nullopt,
                                 "progressive radiosity", kBytesPerElement));
  return {};
}

// The solve: Ctrl-C stops it between two iterations and writes a checkpoint; the lightmap
// into `run`.
Status solveProgressive(ProgressiveRun& run, const Scene& scene,
                        const ProgressiveRunOptions& options, const CommonOptions& common,
                        Communicator& comm, ProgressiveSolver& solver,
                        const ProgressiveOptions& po) {
  const bool gpu = solver.device() == SolverDevice::kGpu;
  ProgressiveRadiosity& pr = *run.solver;
  // From here Ctrl-C stops between two iterations and writes a checkpoint. The line below is
  // printed once it does (scripts may wait for it before sending SIGINT).
  const InterruptScope interrupt;
  spdlog::info("{}: {} lightmap texels in a {}x{} atlas ({:.1f} texels/m){}", scene.source,
               pr.elementCount(), pr.atlas().width, pr.atlas().height, pr.atlas().texel_density,
               gpu ? fmt::format(", on the GPU (shooter level {})", po.shooter_level) : "");

  // Progress: the fraction of the emitted power shot so far on a log scale down to the tolerance
  // (the iteration count is not known in advance), with the iteration and the unshot fraction.
  Progress progress("shooting", 1000, !common.quiet && comm.root() && Progress::stderrIsTerminal());
  const double log_goal = std::log(std::max(options.tolerance, 1e-12));
  const auto after = [&](const ProgressiveIteration& it) {
    run.history.push_back(it.unshot_fraction);
    if (it.shooter == ProgressiveRadiosity::kLights) {
      run.shooters.push_back("lights");
    } else {
      run.shooters.push_back(it.shooter);
    }
    run.iteration_seconds.push_back(it.seconds);
    const double f = it.unshot_fraction > 0.0 ? std::log(it.unshot_fraction) / log_goal : 1.0;
    progress.setNote(fmt::format("iteration {}, {:.3g} unshot", it.iteration, it.unshot_fraction));
    progress.reach(uint64_t(std::clamp(f, 0.0, 1.0) * 1000.0));
  };
  // Over several ranks all stop at the same iteration: when any of them was asked to (mpirun
  // passes SIGUSR1 on to every rank, not at the same instant).
  const auto stop = [&] {
    const uint8_t mine = InterruptScope::requested() ? 1 : 0;
    if (!comm.distributed()) return mine != 0;
    for (uint8_t r : allgatherValue(comm, mine)) {
      if (r) return true;
    }
    return false;
  };
  Expected<ProgressiveStats> st = solver.solve(after, stop);
  if (!st) return st.error();
  run.stats = *st;
  // The solution into the CPU object (checkpoints, stats, baking), and the lightmap (on the GPU
  // through its own post-process, sec. 3.1).
  PENUMBRA_TRY(solver.sync());
  Expected<Image> lightmap = solver.radianceImage();
  if (!lightmap) return lightmap.error();
  run.lightmap = std::move(*lightmap);
  progress.finish();
  if (run.stats.interrupted) {
    run.interrupted = true;
    // Every rank holds the whole state: rank 0 writes it, and any rank count can resume it.
    if (comm.root()) PENUMBRA_TRY(writeProgressiveCheckpoint(options.checkpoint, scene, pr));
    spdlog::warn(
        "interrupted after {} iterations ({:.3g} of the emitted power unshot): checkpoint "
        "written to {}; continue with --resume {}",
        run.stats.total_iterations, run.stats.unshot_fraction, options.checkpoint,
        options.checkpoint);
  } else if (!options.resume.empty() && !options.keep_checkpoint) {
    // The run completed: the checkpoint it continued is stale. It goes once the outputs are in
    // place (kept if they fail).
    OutputTransaction* t = OutputTransaction::current();
    if (t && comm.root()) t->removeOnCommit(options.resume);
  }
  if (!run.interrupted && !run.stats.converged) {
    spdlog::warn(
        "not converged: {:.3g} of the emitted power unshot after {} iterations "
        "(tolerance {:.3g})",
        run.stats.unshot_fraction, run.stats.total_iterations, options.tolerance);
  }
  return {};
}

}  // namespace

Status checkLightmapPlan(const Scene& scene, const LightmapResolution& resolution,
                         std::optional<uint64_t> checkpoint_elements, const std::string& method,
                         uint64_t bytes_per_element) {
  // The texels the plan asks for, from the option that sizes the lightmap, counted before
  // anything is built.
  const uint64_t expected =
      checkpoint_elements ? *checkpoint_elements : expectedLightmapElements(scene, resolution);
  const char* sized_by = checkpoint_elements        ? "the checkpoint's lightmap"
                         : resolution.texel_density ? "--texel-density"
                         : resolution.size          ? "--lightmap-size"
                                                    : "--elements";
  if (expected > uint64_t(UINT32_MAX)) {
    return inputError("", sized_by,
                      fmt::format("{} with {} lightmap texels: more than a lightmap can index",
                                  method, expected));
  }
  return checkMemory(expected * bytes_per_element,
                     fmt::format("{} with {} lightmap texels ({})", method, expected, sized_by));
}

Status checkResumedOption(const std::vector<std::string>& given, const std::string& checkpoint,
                          const std::string& name, const std::string& fixed,
                          const std::string& asked) {
  if (fixed == asked || std::find(given.begin(), given.end(), name) == given.end()) return {};
  return inputError(checkpoint, "",
                    fmt::format("was written with --{} {}, not {}; the checkpoint fixes it (leave "
                                "--{} out to continue it)",
                                name, fixed, asked, name));
}

Status checkProgressiveRunOptions(const ProgressiveRunOptions& o) {
  if (o.texel_density && !(*o.texel_density > 0.0 && std::isfinite(*o.texel_density))) {
    return inputError("", "--texel-density", "must be a positive number of texels per metre");
  }
  if (!(o.tolerance >= 0.0 && o.tolerance <= 1.0)) {
    return inputError("", "--tolerance", "is the unshot fraction of the emitted power: in [0, 1]");
  }
  if (!o.resume.empty() && o.lightmap_size) {
    return inputError("", "--resume",
                      "the checkpoint fixes the lightmap: leave out --lightmap-size");
  }
  if (!o.checkpoint.empty()) PENUMBRA_TRY(checkOutputPath(o.checkpoint));
  if (Status s = checkSubdivisionOptions(o.subdivision); !s.ok()) {
    return inputError("", "--boundary/--finest-level/--min-share", s.error().message);
  }
  return {};
}

Expected<ProgressiveRun> runProgressive(const Scene& scene, const ProgressiveRunOptions& options,
                                        const CommonOptions& common, ReadyGate* gate) {
  ProgressiveRun run;
  if (options.device == "hybrid") {
    return inputError("", "--device", "hybrid applies to the Ray Engine (trace, pathtrace)");
  }
  ProgressiveOptions po;
  std::optional<ProgressiveCheckpointInfo> info;
  PENUMBRA_TRY(prepareProgressive(scene, options, po, info));

  Communicator& comm = currentCommunicator();
  Expected<std::string> device_name =
      radiosityDeviceOverRanks(comm, options.device, "progressive radiosity");
  if (!device_name) return device_name.error();
  Expected<DeviceChoice> device = chooseDevice(*device_name);
  if (!device) return device.error();
  const bool gpu = device->device == Device::kGpu;
  run.device = device->name();
  if (gpu && info && info->shooter_top_points > 0) {
    return inputError(options.resume, "",
                      "was written by the CPU's hierarchical shooter; continue it with --device "
                      "cpu");
  }
  if (gate) PENUMBRA_TRY(gate->open());
  if (gpu) {
    if (options.shading_normals && !common.dry_run) {
      spdlog::info("--device gpu: form factors use the faces' normals");
    }
    po = gpuProgressiveOptions(po);
  }

  const Timer build_timer;
  Expected<ProgressiveRadiosity> built = ProgressiveRadiosity::build(scene, po);
  if (!built) {
    // Resuming, the lightmap's size comes from the checkpoint, not from an option.
    if (info && built.error().file.empty()) {
      return inputError(options.resume, "",
                        fmt::format("its lightmap ({} texels per metre) cannot be built: {}",
                                    info->texel_density, built.error().message));
    }
    return built.error();
  }
  // A dry run checks what the run would: the lightmap is built (a density that leaves a chart
  // without a texel is refused) and a checkpoint is restored into it (another scene's, or one
  // whose lightmap differs, is refused); nothing is solved or written.
  if (common.dry_run) {
    if (info) PENUMBRA_TRY(resumeProgressiveCheckpoint(options.resume, scene, *built));
    run.dry_run = true;
    return run;
  }
  if (gpu && !info) {
    po.shooter_level = gpuShooterLevel(*built, options.shooter_points);
    PENUMBRA_TRY(built->setShooterLevel(po.shooter_level));
  }
  run.solver.emplace(std::move(*built));
  ProgressiveRadiosity& pr = *run.solver;
  pr.setCommunicator(&comm);
  if (info) {
    PENUMBRA_TRY(resumeProgressiveCheckpoint(options.resume, scene, pr));
    run.resumed_iterations = pr.iterations();
    spdlog::info("{}: resumed after {} iterations, {:.3g} of the emitted power unshot",
                 options.resume, pr.iterations(), pr.unshotFraction());
  }
  Expected<std::unique_ptr<ProgressiveSolver>> solver =
      ProgressiveSolver::create(pr, gpu ? SolverDevice::kGpu : SolverDevice::kCpu);
  if (!solver) return solver.error();
  run.build_seconds = build_timer.seconds();
  PENUMBRA_TRY(solveProgressive(run, scene, options, common, comm, **solver, po));
  return run;
}

nlohmann::json progressiveStatsJson(const ProgressiveRun& run, double tolerance) {
  const ProgressiveRadiosity& pr = *run.solver;
  const EnergyBalance& b = pr.balance();
  return {{"device", run.device},
          {"build_seconds", run.build_seconds},
          {"solve_seconds", run.stats.seconds},
          {"elements", pr.elementCount()},
          {"atlas_width", pr.atlas().width},
          {"atlas_height", pr.atlas().height},
          {"texel_density", pr.atlas().texel_density},
          {"iterations", run.stats.total_iterations},
          {"resumed_iterations", run.resumed_iterations},
          {"unshot_fraction", run.stats.unshot_fraction},
          {"converged", run.stats.converged},
          {"interrupted", run.interrupted},
          {"tolerance", tolerance},
          {"history", run.history},
          {"shooters", run.shooters},
          {"iteration_seconds", run.iteration_seconds},
          {"rays", run.stats.rays},
          {"receivers",
           {{"count", pr.receivers().size()},
            {"level", pr.receiverLevel()},
            {"adaptive", pr.options().adaptive},
            {"boundary",
             {pr.options().subdivision.boundary_low, pr.options().subdivision.boundary_high}},
            {"finest_level", pr.options().subdivision.finest_level},
            {"min_share", pr.options().subdivision.min_share},
            {"refined", run.stats.refined},
            {"subdivision_seconds", run.stats.subdivision_seconds},
            {"subdivision_share",
             run.stats.seconds > 0.0 ? run.stats.subdivision_seconds / run.stats.seconds : 0.0}}},
          {"emitted_w", {b.emitted.x, b.emitted.y, b.emitted.z}},
          {"absorbed_w", {b.absorbed.x, b.absorbed.y, b.absorbed.z}},
          {"unshot_w", {b.unshot.x, b.unshot.y, b.unshot.z}},
          {"escaped_w", {b.escaped.x, b.escaped.y, b.escaped.z}}};
}

}  // namespace penumbra
