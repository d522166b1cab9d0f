// --method pathtrace: the reference path tracer (raytrace/path_tracer.h) on the CPU, as a wavefront
// through the Ray Engine's GPU or hybrid back end, or over MPI ranks in blocks of rows.
#include "penumbra/methods/render.h"
#include "penumbra/raytrace/cutout_filter.h"

#include "penumbra/cluster/distributed_render.h"
#include "penumbra/core/file_util.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/timer.h"
#include "penumbra/io/image_io.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/methods/device.h"
#include "penumbra/methods/illuminance_output.h"
#include "penumbra/methods/registry.h"
#include "penumbra/methods/run_context.h"
#include "penumbra/methods/stats_file.h"
#include "penumbra/raytrace/path_tracer.h"
#include "penumbra/raytrace/ray_queries.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>

namespace penumbra {

namespace {

// The path tracer's image on the CPU (`device_name` empty) or as a wavefront through the named
// Ray Engine back end, over the MPI ranks when there are several (rank 0 gets the image).
Expected<Image> renderImage(const PathTracer& tracer, const Camera& camera,
                            const PathTracerSettings& settings, const std::string& device_name,
                            const std::function<void(int)>& on_rows, PathTracerStats* stats_out,
                            std::optional<DistributedRenderStats>* distributed_out) {
  Communicator& comm = currentCommunicator();
  // Devices: the CPU traces paths one by one; gpu and hybrid advance them as a wavefront whose
  // batches go to the Ray Engine's GPU kernel or its CPU/GPU split (same image).
  std::unique_ptr<OwnedRayQueries> queries;
  if (!device_name.empty()) {
    Expected<std::unique_ptr<OwnedRayQueries>> q =
        OwnedRayQueries::make(device_name, tracer.geometry());
    if (!q) return q.error();
    queries = std::move(*q);
  }
  PathTracerStats& stats = *stats_out;
  std::optional<DistributedRenderStats>& distributed = *distributed_out;
  Image image;
  if (comm.distributed()) {
    // Blocks of rows handed out on demand; rank 0 gets the image (cluster/distributed_render.h).
    Timer timer;
    std::atomic<int> rows_in{0};
    distributed.emplace();
    image = renderOverRanks(
        comm, settings.width, settings.height, rowBlockSize(settings.height, comm.size()),
        [&](int y0, int y1, std::span<glm::vec3> out) -> uint64_t {
          if (!queries) return tracer.renderRows(camera, settings, y0, y1, out);
          Expected<uint64_t> rays =
              tracer.renderRowsWavefront(camera, settings, y0, y1, *queries, out);
          if (!rays) throw ClusterError(rays.error().describe());
          return *rays;
        },
        [&](int rows) { on_rows(rows_in += rows); }, &*distributed);
    stats.rays = distributed->rays;
    stats.seconds = timer.seconds();
  } else if (!queries) {
    image = tracer.render(camera, settings, &stats, on_rows);
  } else {
    Expected<Image> img = tracer.renderWavefront(camera, settings, *queries, &stats, on_rows);
    if (!img) return img.error();
    image = std::move(*img);
  }
  return image;
}

}  // namespace

Status renderPathTrace(const RenderOptions& options, const CommonOptions& common) {
  // Over several processes (mpirun): every rank loads and checks, then they agree to start.
  Communicator& comm = currentCommunicator();
  ReadyGate gate(comm);
  Expected<std::vector<std::string>> checked = checkRenderOutputs(options, 1);
  if (!checked) return checked.error();
  const std::vector<std::string>& outputs = *checked;

  Timer load_timer;
  const Scene* const scene = &runScene();
  for (const std::string& w : scene->warnings) spdlog::warn("{}", w);

  PathTracerSettings settings;
  settings.width = options.width.value_or(settings.width);
  settings.height = options.height.value_or(settings.height);
  settings.spp = options.spp.value_or(settings.spp);
  settings.max_depth = options.max_depth.value_or(settings.max_depth);
  if (options.seed) settings.seed = *options.seed;
  if (options.sampler) settings.low_discrepancy = *options.sampler == "sobol";
  // The image, its tone-mapped copy and the file buffers: about 40 bytes per pixel.
  PENUMBRA_TRY(checkMemory(uint64_t(settings.width) * uint64_t(settings.height) * 40,
                           fmt::format("a {}x{} image", settings.width, settings.height)));

  const Camera camera = scene->camera ? *scene->camera : defaultCamera(*scene);
  std::optional<IlluminanceRequest> lux;
  if (wantsIlluminance(options)) {
    Expected<IlluminanceRequest> r = illuminanceRequest(options, settings.width, settings.height);
    if (!r) return r.error();
    lux = *r;
  }
  PENUMBRA_TRY(prepareIlluminance(lux, options, *scene, settings.width, settings.height));
  const double load_seconds = load_timer.seconds();
  Timer build_timer;
  const PathTracer tracer(*scene);
  const double build_seconds = build_timer.seconds();
  if (tracer.geometry().emitters.empty() && !hasLightOtherThanSurfaces(*scene)) {
    return noLightError(*scene, "pathtrace");
  }
  // Devices: the CPU traces paths one by one; gpu and hybrid advance them as a wavefront whose
  // batches go to the Ray Engine's GPU kernel or its CPU/GPU split (same image).
  const bool hybrid = options.device == "hybrid";
  Expected<DeviceChoice> device = chooseDevice(hybrid ? "gpu" : options.device);
  if (!device) return device.error();
  const std::string device_name = hybrid ? std::string("hybrid") : device->name();
  PENUMBRA_TRY(gate.open());
  if (common.dry_run) return {};
  spdlog::info("{}: {} triangles, {} emissive, {} lights; {}x{} at {} spp on {} threads{}",
               scene->source, tracer.geometry().triangles.size(), tracer.geometry().emitters.size(),
               scene->lights.size(), settings.width, settings.height, settings.spp, threadCount(),
               comm.distributed() ? fmt::format(" x {} ranks", comm.size()) : std::string());

  Progress progress("rendering", uint64_t(settings.height),
                    !common.quiet && comm.root() && Progress::stderrIsTerminal());
  // Both renderers report the number of rows finished so far (from any thread).
  const auto on_rows = [&](int rows) { progress.reach(uint64_t(rows)); };
  PathTracerStats stats;
  std::optional<DistributedRenderStats> distributed;
  Expected<Image> rendered =
      renderImage(tracer, camera, settings, device->device == Device::kCpu ? "" : device_name,
                  on_rows, &stats, &distributed);
  if (!rendered) return rendered.error();
  const Image& image = *rendered;
  progress.finish();
  if (!comm.root()) return {};  // rank 0 writes the outputs

  // Lux: the path tracer's radiance gathered over each point's hemisphere.
  std::optional<IlluminanceReport> report;
  if (lux) {
    const FlatTriangles flat = flattenScene(*scene);
    RayEngine engine = RayEngine::build(flat.positions, flat.triangles);
    engine.setHitFilter(cutoutFilter(tracer.geometry().textures));
    Expected<IlluminanceReport> r = illuminanceReport(
        *scene, engine, flat, camera, *lux, [&](const Ray& ray, const Hit&, Rng& rng) {
          uint64_t rays = 0;
          return tracer.radiance(ray, rng, settings, rays);
        });
    if (!r) return r.error();
    report = std::move(*r);
  }
  nlohmann::json lux_stats = nlohmann::json::object();
  emitImage(renderedValues(options, image, report ? &*report : nullptr));
  PENUMBRA_TRY(
      writeRenderOutputs(options, outputs, image, report ? &*report : nullptr, &lux_stats));
  const double mrays = stats.seconds > 0.0 ? double(stats.rays) / stats.seconds * 1e-6 : 0.0;
  spdlog::info("rendered in {:.2f} s ({:.2f} Mrays/s); wrote {}", stats.seconds, mrays,
               fmt::join(outputs, ", "));
  if (wantsStats(options.stats)) {
    nlohmann::json j = {{"method", "pathtrace"},
                        {"device", device_name},
                        {"scene", scene->source},
                        {"seconds", stats.seconds},
                        {"load_seconds", load_seconds},
                        {"build_seconds", build_seconds},
                        {"width", settings.width},
                        {"height", settings.height},
                        {"spp", settings.spp},
                        {"max_depth", settings.max_depth},
                        {"seed", settings.seed},
                        {"sampler", settings.low_discrepancy ? "sobol" : "independent"},
                        {"threads", threadCount()},
                        {"triangles", tracer.geometry().triangles.size()},
                        {"rays", stats.rays},
                        {"mrays_per_s", mrays}};
    j.update(lux_stats);
    if (distributed) {
      j["ranks"] = comm.size();
      j["threads_per_rank"] = threadCount();
      j["block_rows"] = distributed->block_rows;
      j["blocks_per_rank"] = distributed->blocks_per_rank;
      j["rays_per_rank"] = distributed->rays_per_rank;
      j["bytes_received"] = distributed->bytes_received;
      j["mpi"] = comm.describe();
    }
    PENUMBRA_TRY(emitStats(options.stats, j));
  }
  return {};
}

}  // namespace penumbra
