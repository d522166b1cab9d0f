// `penumbra render --method matrix`: matrix radiosity (Carr, Hall, Hart 2003, sec. 3) on the
// scene's elements, viewed from the camera with smooth interpolation, optionally as a sequence
// of relit frames (dynamic relighting: the form factors are computed once).
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
#include "penumbra/methods/matrix_build.h"
#include "penumbra/methods/render.h"
#include "penumbra/methods/run_context.h"
#include "penumbra/methods/stats_file.h"
#include "penumbra/radiosity/matrix_radiosity.h"
#include "penumbra/radiosity/radiosity_solvers.h"
#include "penumbra/render/lightmap_view.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <filesystem>
#include <mutex>
#include <optional>

namespace penumbra {

namespace {

// The emitters' colour in frame f of n: a tint that goes once around the hue circle, with the
// same mean over the sequence as the scene's own emission.
glm::vec3 relightTint(int f, int n) {
  const float a = 2.0f * 3.14159265f * float(f) / float(n);
  return glm::vec3(1.0f + 0.8f * std::cos(a), 1.0f + 0.8f * std::cos(a - 2.0943951f),
                   1.0f + 0.8f * std::cos(a + 2.0943951f));
}

// What the options ask of a matrix render, checked before the scene is loaded.
struct MatrixSetup {
  int frames = 1;
  std::vector<std::string> outputs;
  int width = 512, height = 512, spp = 4;
  std::optional<IlluminanceRequest> lux;
};

// The options' checks, in the order the command makes them.
Expected<MatrixSetup> checkMatrixOptions(const RenderOptions& options) {
  MatrixSetup setup;
  setup.frames = options.relight_frames > 1 ? options.relight_frames : 1;
  Expected<std::vector<std::string>> checked = checkRenderOutputs(options, setup.frames);
  if (!checked) return checked.error();
  setup.outputs = *checked;
  if (options.max_depth) {
    return inputError("", "--max-depth", "applies to --method pathtrace only");
  }
  setup.width = options.width.value_or(512);
  setup.height = options.height.value_or(512);
  setup.spp = options.spp.value_or(4);
  // Ranges: methods/registry.cpp.
  if (setup.frames > 1 && !options.grid_csv.empty()) {
    return inputError("", "--grid-csv", "writes one frame's table: not with --relight-frames");
  }
  if (wantsIlluminance(options)) {
    Expected<IlluminanceRequest> r = illuminanceRequest(options, setup.width, setup.height);
    if (!r) return r.error();
    setup.lux = *r;
  }
  PENUMBRA_TRY(checkMemory(uint64_t(setup.width) * uint64_t(setup.height) * 40,
                           fmt::format("a {}x{} image", setup.width, setup.height)));
  return setup;
}

// What the frames leave for the stats.
struct MatrixFrameTotals {
  nlohmann::json frame_stats = nlohmann::json::array();
  nlohmann::json lux_stats = nlohmann::json::object();  // the last frame's
  SolveStats last;
  double solve_seconds = 0.0, view_seconds = 0.0;
};

// Solves each frame (relit when there are several), and on rank 0 draws and writes it.
Status renderMatrixFrames(const RenderOptions& options, const CommonOptions& common,
                          Communicator& comm, const MatrixSetup& setup, const Scene& scene,
                          MatrixRadiosity& mr, MatrixRadiositySolver& device_solver,
                          MatrixSolver solver, const Camera& camera,
                          const LightmapViewSettings& view, MatrixFrameTotals& totals) {
  const int frames = setup.frames;
  const std::optional<IlluminanceRequest>& lux = setup.lux;
  std::vector<Material> materials = scene.materials;
  SolveStats& last = totals.last;
  for (int f = 0; f < frames; ++f) {
    if (frames > 1) {
      const glm::vec3 tint = relightTint(f, frames);
      for (size_t m = 0; m < materials.size(); ++m) {
        materials[m].emission = scene.materials[m].emission * tint;
      }
      mr.applyMaterials(materials);
      PENUMBRA_TRY(device_solver.relight());
    }
    SolveOptions so;
    so.solver = solver;
    so.max_iterations = iterationCap(options.iterations);
    so.tolerance = options.tolerance.value_or(1e-6);
    Progress progress(frames > 1 ? fmt::format("solving frame {}", f) : std::string("solving"),
                      uint64_t(so.max_iterations),
                      !common.quiet && comm.root() && Progress::stderrIsTerminal());
    auto on_iteration = [&](int k, double) { progress.reach(uint64_t(k + 1)); };
    Expected<SolveStats> solved = device_solver.solve(so, on_iteration);
    if (!solved) return solved.error();
    last = std::move(*solved);
    progress.finish();
    totals.solve_seconds += last.seconds;
    if (!last.converged) {
      spdlog::warn("not converged: residual {:.3g} after {} iterations (tolerance {:.3g})",
                   last.residual, last.iterations, so.tolerance);
    }
    const Timer view_timer;
    const Image lightmap = mr.radianceImage(options.shading == "smooth");
    if (!comm.root()) continue;  // rank 0 draws and writes
    const std::shared_ptr<const LightmapDetail> detail = mr.surface.lightmapDetail();
    const Image image = renderLightmapView(mr.surface.flat.positions, mr.surface.flat.triangles,
                                           mr.surface.atlas, lightmap, camera, view, detail.get());
    totals.view_seconds += view_timer.seconds();
    // Lux: the lightmap's radiance gathered over each point's hemisphere (each frame's).
    std::optional<IlluminanceReport> report;
    if (lux) {
      const LightmapLookup lookup(mr.surface.flat.positions, mr.surface.flat.triangles,
                                  mr.surface.atlas, lightmap, detail.get());
      Expected<IlluminanceReport> r =
          illuminanceReport(scene, mr.surface.engine, mr.surface.flat, camera, *lux,
                            [&](const Ray& ray, const Hit& hit, Rng&) {
                              return lookup.radiance(ray.dir, hit.triangle, hit.u, hit.v);
                            });
      if (!r) return r.error();
      report = std::move(*r);
    }
    emitImage(renderedValues(options, image, report ? &*report : nullptr));
    if (frames == 1) {
      PENUMBRA_TRY(writeRenderOutputs(options, setup.outputs, image, report ? &*report : nullptr,
                                      &totals.lux_stats));
    } else {
      for (const std::string& out : setup.outputs) {
        PENUMBRA_TRY(writeRenderOutputs(options, {out}, image, report ? &*report : nullptr,
                                        &totals.lux_stats, sequenceFrameName(out, f)));
      }
    }
    spdlog::info("{}{} iterations ({}), residual {:.3g}, {:.3f} s",
                 frames > 1 ? fmt::format("frame {}: ", f) : "", last.iterations,
                 matrixSolverName(solver), last.residual, last.seconds);
    totals.frame_stats.push_back({{"iterations", last.iterations},
                                  {"residual", last.residual},
                                  {"converged", last.converged},
                                  {"seconds", last.seconds}});
  }
  return {};
}

// The render's stats (--stats).
nlohmann::json matrixStats(const RenderOptions& options, Communicator& comm,
                           const MatrixSetup& setup, const DeviceChoice& device, const Scene& scene,
                           const Timer& total_timer, MatrixSolver solver,
                           const MatrixRadiosityOptions& mo, const MatrixRadiosity& mr,
                           double build_seconds, const MatrixFrameTotals& totals) {
  const SolveStats& last = totals.last;
  nlohmann::json j = {{"method", "matrix"},
                      {"device", device.name()},
                      {"scene", scene.source},
                      {"seconds", total_timer.seconds()},
                      {"solver", matrixSolverName(solver)},
                      {"precision", matrixPrecisionName(mo.precision)},
                      {"elements", mr.size()},
                      {"lightmap_elements", mr.surface.elementCount()},
                      {"atlas_width", mr.surface.atlas.width},
                      {"atlas_height", mr.surface.atlas.height},
                      {"texel_density", mr.surface.atlas.texel_density},
                      {"matrix_bytes", mr.system->matrixBytes()},
                      {"form_factor_seconds", mr.form_factor_stats.seconds},
                      {"form_factor_pairs", mr.form_factor_stats.pairs},
                      {"form_factor_rays", mr.form_factor_stats.rays},
                      {"form_factor_refined", mr.form_factor_stats.refined},
                      {"closed_rows", mr.form_factor_stats.closed_rows},
                      {"rays", mr.form_factor_stats.rays},
                      {"build_seconds", build_seconds},
                      {"solve_seconds", totals.solve_seconds},
                      {"view_seconds", totals.view_seconds},
                      {"iterations", last.iterations},
                      {"residual", last.residual},
                      {"converged", last.converged},
                      {"tolerance", options.tolerance.value_or(1e-6)},
                      {"history", last.history},
                      {"threads", threadCount()},
                      {"width", setup.width},
                      {"height", setup.height},
                      {"spp", setup.spp}};
  // What the sky or the environment brings to the surfaces directly (W per channel).
  j["outside_power_w"] = {mr.outside_power.x, mr.outside_power.y, mr.outside_power.z};
  if (setup.frames > 1) j["frames"] = totals.frame_stats;
  if (comm.distributed()) {
    j["ranks"] = comm.size();
    j["mpi"] = comm.describe();
    j["matrix_bytes_per_rank"] = mr.system->matrixBytes();
  }
  j.update(totals.lux_stats);
  return j;
}

}  // namespace

Status renderMatrix(const RenderOptions& options, const CommonOptions& common) {
  // Over several processes (mpirun): every rank loads and checks, then they agree to start; each
  // holds a block of the matrix's rows (radiosity/matrix_radiosity.h), rank 0 draws and writes.
  Communicator& comm = currentCommunicator();
  ReadyGate gate(comm);
  Expected<MatrixSetup> setup = checkMatrixOptions(options);
  if (!setup) return setup.error();

  const Timer total_timer;
  const Scene* const scene = &runScene();
  for (const std::string& w : scene->warnings) spdlog::warn("{}", w);
  for (const std::string& w : diffuseStandInWarnings(*scene, "matrix")) spdlog::warn("{}", w);
  PENUMBRA_TRY(prepareIlluminance(setup->lux, options, *scene, setup->width, setup->height));

  MatrixRadiosityOptions mo;
  mo.elements = options.elements.value_or(kMatrixDefaultElements);
  mo.lightmap.texel_density = options.texel_density;
  if (options.ff_rays) mo.form_factors.rays = *options.ff_rays;
  mo.form_factors.seed = options.seed.value_or(0);
  mo.precision = options.precision == "fp16" ? MatrixPrecision::kFp16 : MatrixPrecision::kFp32;
  mo.shading_normals = options.normals == "interpolated";
  PENUMBRA_TRY(checkMatrixRadiosity(*scene, mo, comm.size()));

  Expected<std::string> device_name =
      radiosityDeviceOverRanks(comm, options.device, "matrix radiosity");
  if (!device_name) return device_name.error();
  Expected<DeviceChoice> device = chooseDevice(*device_name);
  if (!device) return device.error();
  const bool gpu = device->device == Device::kGpu;
  Expected<MatrixSolver> solver = matrixSolverFor(
      gpu ? SolverDevice::kGpu : SolverDevice::kCpu,
      options.solver
          ? std::optional<MatrixSolver>(*options.solver == "jacobi" ? MatrixSolver::kJacobi
                                                                    : MatrixSolver::kGaussSeidel)
          : std::nullopt);
  if (!solver) return solver.error();
  PENUMBRA_TRY(gate.open());
  if (common.dry_run) return {};

  const Timer build_timer;
  Expected<MatrixRadiosity> built = buildMatrixWithProgress(*scene, mo, common);
  if (!built) return built.error();
  MatrixRadiosity& mr = *built;
  const double build_seconds = build_timer.seconds();
  const size_t n = mr.size();
  spdlog::info(
      "{}: {} elements (clusters of {} lightmap texels, {}x{} atlas), {:.3g} M form factors in "
      "{:.2f} s ({} rays)",
      scene->source, n, mr.surface.elementCount(), mr.surface.atlas.width, mr.surface.atlas.height,
      double(n) * double(n) * 1e-6, mr.form_factor_stats.seconds, mr.form_factor_stats.rays);

  Expected<std::unique_ptr<MatrixRadiositySolver>> device_solver =
      MatrixRadiositySolver::create(mr, gpu ? SolverDevice::kGpu : SolverDevice::kCpu);
  if (!device_solver) return device_solver.error();

  const Camera camera = scene->camera ? *scene->camera : defaultCamera(*scene);
  LightmapViewSettings view;
  view.width = setup->width;
  view.height = setup->height;
  view.spp = setup->spp;
  view.seed = options.seed.value_or(0);
  MatrixFrameTotals totals;
  PENUMBRA_TRY(renderMatrixFrames(options, common, comm, *setup, *scene, mr, **device_solver,
                                  *solver, camera, view, totals));

  if (!comm.root()) return {};
  if (wantsStats(options.stats)) {
    PENUMBRA_TRY(
        emitStats(options.stats, matrixStats(options, comm, *setup, *device, *scene, total_timer,
                                             *solver, mo, mr, build_seconds, totals)));
  }
  return {};
}

Expected<MatrixRadiosity> buildMatrixWithProgress(const Scene& scene,
                                                  const MatrixRadiosityOptions& options,
                                                  const CommonOptions& common) {
  Communicator& comm = currentCommunicator();
  // The form factors' row count is known once the cut is made: the bar starts with the first row.
  std::optional<Progress> progress;
  std::once_flag once;
  Expected<MatrixRadiosity> built = buildMatrixRadiosity(
      scene, options,
      [&](size_t done, size_t rows) {
        std::call_once(once, [&] {
          progress.emplace("form factors", uint64_t(rows),
                           !common.quiet && comm.root() && Progress::stderrIsTerminal());
        });
        progress->reach(done);
      },
      &comm);
  if (progress) progress->finish();
  if (!built) return built;
  // Nothing emits once cut-outs are taken into account (an emitter of holes), and no light comes
  // from elsewhere: refused as every method refuses it (scene/scene.h).
  bool emits = hasLightOtherThanSurfaces(scene);
  for (const glm::dvec3& e : built->surface.emission) emits = emits || e != glm::dvec3(0.0);
  if (!emits) return noLightError(scene, "matrix radiosity");
  return built;
}

}  // namespace penumbra
