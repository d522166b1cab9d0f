// `penumbra trace`: the Ray Engine as a service (design doc sec. 4).
#include "penumbra/app/commands.h"
#include "penumbra/app/device.h"
#include "penumbra/app/stats_file.h"
#include "penumbra/app/trace_run.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/io/ray_file.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/raytrace/hybrid.h"
#include "penumbra/raytrace/ray_engine.h"
#include "penumbra/raytrace/ray_engine_gl.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <filesystem>

namespace penumbra {

Status checkTraceOptions(const TraceOptions& options) {
  if (options.device != "cpu" && options.device != "gpu" && options.device != "auto" &&
      options.device != "hybrid") {
    return inputError("", "",
                      fmt::format("--device '{}': use cpu, gpu, hybrid or auto", options.device));
  }
  if (options.t_min > options.t_max) {
    return inputError(
        "", "", fmt::format("--t-min {} is larger than --t-max {}", options.t_min, options.t_max));
  }
  if (options.cache_rays && *options.cache_rays < options.r_min) {
    return inputError("", "",
                      fmt::format("--cache-rays {} is smaller than --r-min {}: the cache must hold "
                                  "a bucket",
                                  *options.cache_rays, options.r_min));
  }
  return {};
}

Expected<TraceRun> traceScene(const Scene& scene, const RayBatch& rays, const TraceOptions& options,
                              bool dry_run) {
  PENUMBRA_TRY(checkTraceOptions(options));
  const FlatTriangles flat = flattenScene(scene);
  const std::vector<glm::vec3>& positions = flat.positions;
  const std::vector<glm::uvec3>& triangles = flat.triangles;
  // hybrid: the CPU/GPU split of the Ray Engine paper (sec. 6.2); it needs a GPU context.
  const bool hybrid = options.device == "hybrid";
  Expected<DeviceChoice> device = chooseDevice(hybrid ? "gpu" : options.device);
  if (!device) return device.error();
  TraceRun run;
  if (dry_run) return run;

  // The answers' buffers are made before the clock starts, as a caller of the library would
  // hold them: trace_seconds is the intersection alone (docs/cli.md).
  HitBatch& hits = run.hits;
  std::vector<uint8_t>& occluded = run.occluded;
  if (options.occlusion) {
    occluded.assign(rays.size(), 0);
  } else {
    hits.resize(rays.size());
  }
  // GPU back ends answer occlusion with closest hits: occluded exactly when one exists.
  const auto gpuOcclusion = [&] {
    if (!options.occlusion) return;
    for (size_t i = 0; i < hits.size(); ++i) occluded[i] = hits.triangle[i] >= 0 ? 1 : 0;
    hits = HitBatch();
  };
  double build_seconds = 0.0, trace_seconds = 0.0;
  size_t bvh_nodes = 0, bvh_bytes = 0;
  nlohmann::json gpu_info;
  nlohmann::json hybrid_stats;
  if (hybrid) {
    Timer build_timer;
    HybridOptions split;
    split.t_min = options.t_min;
    split.t_max = options.t_max;
    split.r_min = options.r_min;
    split.cache_rays = options.cache_rays.value_or(0);  // 0: the default, 4 r_min
    Expected<HybridRayEngine> engine = HybridRayEngine::build(positions, triangles, split);
    if (!engine) return engine.error();
    glFinish();
    build_seconds = build_timer.seconds();
    Timer trace_timer;
    HybridStats hs;
    PENUMBRA_TRY(engine->intersect(rays, hits, &hs));
    gpuOcclusion();
    trace_seconds = trace_timer.seconds();
    const GlDeviceInfo& info = device->context->info();
    gpu_info = {
        {"renderer", info.renderer}, {"version", info.version}, {"software", info.software}};
    hybrid_stats = {{"t_min", options.t_min},
                    {"t_max", options.t_max},
                    {"r_min", options.r_min},
                    {"cache_rays", engine->options().cache_rays},
                    {"gpu_cells", hs.gpu_cells},
                    {"gpu_batches", hs.gpu_batches},
                    {"gpu_ray_cells", hs.gpu_ray_cells},
                    {"forced_ray_cells", hs.forced_ray_cells},
                    {"gpu_triangles", hs.gpu_triangles},
                    {"gpu_triangles_culled", hs.gpu_triangles_culled}};
  } else if (device->device == Device::kGpu) {
    Timer build_timer;
    Expected<GlRayEngine> engine = GlRayEngine::build(positions, triangles);
    if (!engine) return engine.error();
    glFinish();
    build_seconds = build_timer.seconds();
    Timer trace_timer;
    PENUMBRA_TRY(engine->intersect(rays, hits));
    gpuOcclusion();
    trace_seconds = trace_timer.seconds();
    const GlDeviceInfo& info = device->context->info();
    gpu_info = {
        {"renderer", info.renderer}, {"version", info.version}, {"software", info.software}};
  } else {
    Timer build_timer;
    const RayEngine engine = RayEngine::build(positions, triangles);
    build_seconds = build_timer.seconds();
    Timer trace_timer;
    if (options.occlusion) {
      engine.occluded(rays, occluded);
    } else {
      engine.intersect(rays, hits);
    }
    trace_seconds = trace_timer.seconds();
    bvh_nodes = engine.wideNodeCount();
    bvh_bytes = engine.memoryBytes();
  }

  size_t hit_count = 0;
  if (options.occlusion) {
    for (uint8_t o : occluded) hit_count += o;
  } else {
    for (int32_t t : hits.triangle) hit_count += t >= 0;
  }
  const double mrays = trace_seconds > 0.0 ? double(rays.size()) / trace_seconds * 1e-6 : 0.0;
  spdlog::info(
      "{} rays against {} triangles: {} {}; build {:.3f} s, trace {:.3f} s "
      "({:.2f} Mrays/s)",
      rays.size(), triangles.size(), hit_count, options.occlusion ? "occluded" : "hits",
      build_seconds, trace_seconds, mrays);
  run.stats = {{"method", options.occlusion ? "trace-occlusion" : "trace"},
               {"device", hybrid ? std::string("hybrid") : device->name()},
               {"seconds", build_seconds + trace_seconds},
               {"build_seconds", build_seconds},
               {"trace_seconds", trace_seconds},
               {"rays", rays.size()},
               {"hits", hit_count},
               {"triangles", triangles.size()},
               {"threads", threadCount()},
               {"bvh_nodes", bvh_nodes},
               {"bvh_bytes", bvh_bytes},
               {"mrays_per_s", mrays}};
  // A software GPU (llvmpipe) gives correctness runs: its timings say nothing of a GPU.
  if (!gpu_info.is_null()) run.stats["gpu"] = gpu_info;
  if (!hybrid_stats.is_null()) run.stats["hybrid"] = hybrid_stats;
  return run;
}

namespace {

Status trace(const TraceOptions& options, const CommonOptions& common) {
  PENUMBRA_TRY(checkTraceOptions(options));
  PENUMBRA_TRY(checkOutputPath(options.output));
  if (!options.stats.empty()) PENUMBRA_TRY(checkOutputPath(options.stats));
  std::error_code ec;
  const auto ray_bytes = std::filesystem::file_size(options.rays, ec);
  if (!ec) {
    // Rays in SoA (32 B), hits (16 B), the file bytes and the output buffer (16 B).
    PENUMBRA_TRY(
        checkMemory(uint64_t(ray_bytes) / 32 * 96, fmt::format("tracing {} rays", ray_bytes / 32)));
  }

  Expected<Scene> scene = loadScene(options.mesh);
  if (!scene) return scene.error();
  for (const std::string& w : scene->warnings) spdlog::warn("{}", w);
  Expected<RayBatch> rays = readRayFile(options.rays);
  if (!rays) return rays.error();
  Expected<TraceRun> run = traceScene(*scene, *rays, options, common.dry_run);
  if (!run) return run.error();
  if (common.dry_run) return {};
  if (options.occlusion) {
    PENUMBRA_TRY(writeOcclusionFile(options.output, run->occluded));
  } else {
    PENUMBRA_TRY(writeHitFile(options.output, run->hits));
  }
  if (!options.stats.empty()) PENUMBRA_TRY(writeStatsFile(options.stats, run->stats));
  return {};
}

}  // namespace

int runTrace(const TraceOptions& options, const CommonOptions& common) {
  // The hits and the stats are placed together at the end, or neither is.
  OutputTransaction transaction;
  Status s = trace(options, common);
  if (s.ok() && common.dry_run) return reportDryRun();
  if (s.ok()) s = transaction.commit();
  return s.ok() ? 0 : reportError(s.error());
}

}  // namespace penumbra
