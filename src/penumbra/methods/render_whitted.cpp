// `penumbra render --method whitted | photons`: Whitted ray tracing and photon mapping, the Ray
// Engine paper's other applications, traced in batches through the chosen back end.
#include "penumbra/cluster/distributed_render.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/timer.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/methods/device.h"
#include "penumbra/methods/illuminance_output.h"
#include "penumbra/methods/render.h"
#include "penumbra/methods/run_context.h"
#include "penumbra/methods/stats_file.h"
#include "penumbra/raytrace/photon_map.h"
#include "penumbra/raytrace/ray_queries.h"
#include "penumbra/raytrace/whitted.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <atomic>
#include <optional>

namespace penumbra {

namespace {

WhittedSettings whittedSettings(const RenderOptions& options) {
  WhittedSettings ws;
  ws.width = options.width.value_or(ws.width);
  ws.height = options.height.value_or(ws.height);
  ws.spp = options.spp.value_or(ws.spp);
  ws.max_depth = options.max_depth.value_or(ws.max_depth);
  ws.light_samples = options.light_samples.value_or(ws.light_samples);
  ws.seed = options.seed.value_or(0);
  return ws;
}

PhotonSettings photonSettings(const RenderOptions& options, uint64_t seed) {
  PhotonSettings ps;
  ps.seed = seed;
  if (options.method != "photons") return ps;
  if (options.photons) ps.photons = *options.photons;
  if (options.caustic_photons) ps.caustic_photons = *options.caustic_photons;
  ps.gather_count = options.gather_count.value_or(ps.gather_count);
  ps.final_gather = options.final_gather.value_or(ps.final_gather);
  if (options.gather_radius) ps.gather_radius = float(*options.gather_radius);
  return ps;
}

Status checkRayTracedMemory(const WhittedSettings& ws, const PhotonSettings& ps, bool photons) {
  // The image (about 40 bytes per pixel with its samples and files), a wave of the ray tree and
  // a chunk of gather rays (bounded by whitted.cpp's and photon_map.cpp's chunk sizes: about
  // 384 MiB together at most) and the photons (a global photon lands about four times; 64 bytes
  // each with its index).
  const uint64_t image_bytes =
      uint64_t(ws.width) * uint64_t(ws.height) * (40 + 4 * uint64_t(ws.spp));
  const uint64_t wave_bytes = uint64_t(384) << 20;
  const uint64_t photon_bytes = photons ? (ps.photons * 4 + ps.caustic_photons) * 64 : 0;
  return checkMemory(image_bytes + wave_bytes + photon_bytes,
                     photons ? fmt::format("a {}x{} image with {} + {} photons", ws.width,
                                           ws.height, ps.photons, ps.caustic_photons)
                             : fmt::format("a {}x{} image", ws.width, ws.height));
}

// The photon maps (global and caustic) shot through `queries`, and the diffuse shading that
// gathers them; their figures go to j["photons"].
Expected<DiffuseShading> shootAndGather(const Scene& scene, const WhittedTracer& tracer,
                                        const PhotonSettings& ps, RayQueries& queries, bool show,
                                        PhotonMaps* maps, uint64_t* gather_rays,
                                        nlohmann::json* j) {
  PhotonStats pstats;
  Progress progress("photons", ps.photons + ps.caustic_photons, show);
  Expected<PhotonMaps> shot = shootPhotons(scene, tracer.geometry(), ps, queries, &pstats,
                                           [&](uint64_t traced) { progress.reach(traced); });
  if (!shot) return shot.error();
  progress.finish();
  *maps = std::move(*shot);
  DiffuseShading shading = photonShading(tracer.geometry(), *maps, ps, gather_rays);
  const double emitted = double(pstats.emitted + pstats.caustic_emitted);
  const double photons_per_s = pstats.seconds > 0.0 ? emitted / pstats.seconds : 0.0;
  spdlog::info(
      "{} + {} photons in {:.2f} s ({:.3g} photons/s, {:.3g} rays/s): {} global and {} "
      "caustic stored; gather radius {:.4g} m",
      pstats.emitted, pstats.caustic_emitted, pstats.seconds, photons_per_s,
      pstats.seconds > 0.0 ? double(pstats.rays) / pstats.seconds : 0.0, pstats.stored,
      pstats.caustic_stored, maps->radius);
  (*j)["photons"] = {{"emitted", pstats.emitted},
                     {"caustic_emitted", pstats.caustic_emitted},
                     {"stored", pstats.stored},
                     {"caustic_stored", pstats.caustic_stored},
                     {"rays", pstats.rays},
                     {"seconds", pstats.seconds},
                     {"photons_per_s", photons_per_s},
                     {"build_seconds", pstats.build_seconds},
                     {"precompute_seconds", pstats.precompute_seconds},
                     {"gather_count", ps.gather_count},
                     {"gather_radius", maps->radius},
                     {"final_gather", ps.final_gather},
                     {"memory_bytes", maps->global.memoryBytes() + maps->caustic.memoryBytes()}};
  return shading;
}

}  // namespace

Status renderRayTraced(const RenderOptions& options, const CommonOptions& common) {
  const bool photons = options.method == "photons";
  // Over several processes (mpirun): every rank loads and checks, then they agree to start; each
  // rank shoots the same photons (the same seeds), and blocks of rows are handed out on demand.
  Communicator& comm = currentCommunicator();
  ReadyGate gate(comm);
  Expected<std::vector<std::string>> checked = checkRenderOutputs(options, 1);
  if (!checked) return checked.error();
  const std::vector<std::string>& outputs = *checked;
  // Which options apply, and their ranges: methods/registry.cpp.
  const WhittedSettings ws = whittedSettings(options);
  const PhotonSettings ps = photonSettings(options, ws.seed);
  PENUMBRA_TRY(checkRayTracedMemory(ws, ps, photons));

  Timer load_timer;
  const Scene* const scene = &runScene();
  for (const std::string& w : scene->warnings) spdlog::warn("{}", w);
  const Camera camera = scene->camera ? *scene->camera : defaultCamera(*scene);
  const double load_seconds = load_timer.seconds();
  Timer build_timer;
  const WhittedTracer tracer(*scene);
  const double build_seconds = build_timer.seconds();
  if (tracer.geometry().emitters.empty() && !hasLightOtherThanSurfaces(*scene)) {
    return noLightError(*scene, options.method);
  }
  // Every device traces the same batches: the CPU engine, the GPU kernel or the split.
  const bool hybrid = options.device == "hybrid";
  Expected<DeviceChoice> device = chooseDevice(hybrid ? "gpu" : options.device);
  if (!device) return device.error();
  const std::string back_end = hybrid ? std::string("hybrid") : device->name();
  Expected<std::unique_ptr<OwnedRayQueries>> queries =
      OwnedRayQueries::make(back_end, tracer.geometry());
  if (!queries) return queries.error();
  PENUMBRA_TRY(gate.open());
  if (common.dry_run) return {};
  spdlog::info(
      "{}: {} triangles, {} emissive, {} lights; {}x{} at {} spp, depth {}, {} light "
      "samples on {} ({} threads)",
      scene->source, tracer.geometry().triangles.size(), tracer.geometry().emitters.size(),
      scene->lights.size(), ws.width, ws.height, ws.spp, ws.max_depth, ws.light_samples, back_end,
      threadCount());

  nlohmann::json j = {{"method", options.method},
                      {"device", back_end},
                      {"scene", scene->source},
                      {"load_seconds", load_seconds},
                      {"build_seconds", build_seconds},
                      {"width", ws.width},
                      {"height", ws.height},
                      {"spp", ws.spp},
                      {"max_depth", ws.max_depth},
                      {"light_samples", ws.light_samples},
                      {"seed", ws.seed},
                      {"threads", threadCount()},
                      {"triangles", tracer.geometry().triangles.size()}};
  const bool show = !common.quiet && comm.root() && Progress::stderrIsTerminal();
  PhotonMaps maps;
  DiffuseShading shading;
  uint64_t gather_rays = 0;
  if (photons) {
    Expected<DiffuseShading> shot =
        shootAndGather(*scene, tracer, ps, **queries, show, &maps, &gather_rays, &j);
    if (!shot) return shot.error();
    shading = std::move(*shot);
  }
  Progress progress("rendering", uint64_t(ws.height), show);
  WhittedStats stats;
  Expected<Image> image = Image();
  std::optional<uint64_t> all_rays;  // over ranks: every rank's
  if (comm.distributed()) {
    Timer timer;
    std::atomic<int> rows_in{0};
    DistributedRenderStats distributed;
    *image = renderOverRanks(
        comm, ws.width, ws.height, rowBlockSize(ws.height, comm.size()),
        [&](int y0, int y1, std::span<glm::vec3> out) -> uint64_t {
          WhittedStats block;
          const uint64_t gathered = gather_rays;
          if (Status st = tracer.renderRows(camera, ws, y0, y1, **queries, out, block, {}, shading);
              !st) {
            throw ClusterError(st.error().describe());
          }
          stats.rays += block.rays;
          stats.shadow_rays += block.shadow_rays;
          stats.diffuse_vertices += block.diffuse_vertices;
          return block.rays + block.shadow_rays + (gather_rays - gathered);
        },
        [&](int rows) { progress.reach(uint64_t(rows_in += rows)); }, &distributed);
    stats.seconds = timer.seconds();
    all_rays = distributed.rays;
    j["ranks"] = comm.size();
    j["block_rows"] = distributed.block_rows;
    j["rays_per_rank"] = distributed.rays_per_rank;
  } else {
    image = tracer.render(
        camera, ws, **queries, &stats, [&](int rows) { progress.reach(uint64_t(rows)); }, shading);
    if (!image) return image.error();
  }
  progress.finish();
  if (!comm.root()) return {};  // rank 0 writes the outputs
  emitImage(renderedValues(options, *image, nullptr));
  PENUMBRA_TRY(writeRenderOutputs(options, outputs, *image, nullptr, nullptr));
  const uint64_t rays = all_rays ? *all_rays : stats.rays + stats.shadow_rays + gather_rays;
  const double rays_per_s = stats.seconds > 0.0 ? double(rays) / stats.seconds : 0.0;
  spdlog::info("rendered in {:.2f} s ({:.2f} Mrays/s: {} rays, {} shadow rays{}); wrote {}",
               stats.seconds, rays_per_s * 1e-6, stats.rays, stats.shadow_rays,
               photons ? fmt::format(", {} gather rays", gather_rays) : std::string(),
               fmt::join(outputs, ", "));
  if (wantsStats(options.stats)) {
    j["seconds"] = stats.seconds;
    j["rays"] = rays;
    j["tree_rays"] = stats.rays;
    j["shadow_rays"] = stats.shadow_rays;
    j["diffuse_vertices"] = stats.diffuse_vertices;
    j["mrays_per_s"] = rays_per_s * 1e-6;
    if (photons) j["gather_rays"] = gather_rays;
    PENUMBRA_TRY(emitStats(options.stats, j));
  }
  return {};
}

}  // namespace penumbra
