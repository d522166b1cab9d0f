// The Ray Engine as a service (design doc sec. 4): a scene's triangles and a batch of rays in, the
// answers and the statistics out, on one process or over the ranks of a communicator.
#include "penumbra/methods/trace.h"
#include "penumbra/cluster/communicator.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/io/ray_file.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/methods/device.h"
#include "penumbra/methods/stats_file.h"
#include "penumbra/methods/trace.h"
#include "penumbra/raytrace/cutout_filter.h"
#include "penumbra/raytrace/hybrid.h"
#include "penumbra/raytrace/ray_engine.h"
#include "penumbra/raytrace/ray_engine_gl.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <algorithm>
#include <cstdio>
#include <cstring>
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

namespace {

// Cut-outs (materials with alphaMode MASK or BLEND, MTL map_d) are holes for the rays: the CPU's
// hit filter and the GPU kernel's test read the same textures; the hybrid split's CPU cells do
// not test them.
Expected<std::shared_ptr<const SurfaceTextures>> traceCutouts(const Scene& scene, bool hybrid) {
  std::shared_ptr<const SurfaceTextures> textures = sceneCutoutTextures(scene);
  if (textures && hybrid) {
    return inputError(scene.source, "",
                      "the scene has cut-outs (alpha-masked or partly covering materials), which "
                      "the hybrid back end does not test: use --device cpu or gpu");
  }
  return textures;
}

}  // namespace

Expected<TraceRun> traceScene(const Scene& scene, const RayBatch& rays, const TraceOptions& options,
                              bool dry_run) {
  PENUMBRA_TRY(checkTraceOptions(options));
  // hybrid: the CPU/GPU split of the Ray Engine paper (sec. 6.2); it needs a GPU context.
  const bool hybrid = options.device == "hybrid";
  Expected<DeviceChoice> device = chooseDevice(hybrid ? "gpu" : options.device);
  if (!device) return device.error();
  Expected<std::shared_ptr<const SurfaceTextures>> cutouts = traceCutouts(scene, hybrid);
  if (!cutouts) return cutouts.error();
  TraceRun run;
  if (dry_run) return run;
  const FlatTriangles flat = flattenScene(scene);
  const std::vector<glm::vec3>& positions = flat.positions;
  const std::vector<glm::uvec3>& triangles = flat.triangles;
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
    Expected<GlRayEngine> engine = GlRayEngine::build(positions, triangles, {}, cutouts->get());
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
    RayEngine engine = RayEngine::build(positions, triangles);
    engine.setHitFilter(cutoutFilter(*cutouts));
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

// Rank 0's rays split evenly among the ranks, each rank's share of the eight arrays in turn.
template <typename V>
void scatterArray(Communicator& comm, const V& all, V& mine, std::span<const size_t> offsets) {
  using T = typename V::value_type;
  std::vector<size_t> bytes;
  for (size_t o : offsets) bytes.push_back(o * sizeof(T));
  const std::vector<std::byte> part = comm.scatter(all.data(), bytes, 0);
  mine.resize(part.size() / sizeof(T));
  if (!part.empty()) std::memcpy(mine.data(), part.data(), part.size());
}

// Every rank's answers, in rank order (so in the rays' order), into `all` on rank 0.
template <typename V>
void gatherArray(Communicator& comm, V& mine) {
  using T = typename V::value_type;
  const std::vector<std::byte> all = comm.gather(mine.data(), mine.size() * sizeof(T), 0, nullptr);
  if (!comm.root()) return;
  mine.resize(all.size() / sizeof(T));
  if (!all.empty()) std::memcpy(mine.data(), all.data(), all.size());
}

}  // namespace

Expected<TraceRun> traceOverRanks(Communicator& comm, const Scene& scene, const RayBatch& rays,
                                  const TraceOptions& options) {
  Timer timer;
  const uint64_t total = broadcastValue<uint64_t>(comm, comm.root() ? rays.size() : 0);
  std::vector<size_t> offsets;
  for (int r = 0; r <= comm.size(); ++r) {
    offsets.push_back(r < comm.size() ? shareOf(total, r, comm.size()).begin : total);
  }
  RayBatch mine;
  for (auto member : {&RayBatch::ox, &RayBatch::oy, &RayBatch::oz, &RayBatch::tmin, &RayBatch::dx,
                      &RayBatch::dy, &RayBatch::dz, &RayBatch::tmax}) {
    scatterArray(comm, rays.*member, mine.*member, offsets);
  }
  const double scatter_seconds = timer.seconds();
  Expected<TraceRun> run = traceScene(scene, mine, options, false);
  // A failure here (a GPU that failed on one rank) ends the job: the others wait in the gather.
  if (!run) {
    std::fprintf(stderr, "penumbra: error: rank %d of %d: %s\n", comm.rank(), comm.size(),
                 run.error().describe().c_str());
    comm.abort(1);
  }
  const double trace_seconds = run->stats["trace_seconds"].get<double>();
  Timer gather_timer;
  if (options.occlusion) {
    gatherArray(comm, run->occluded);
  } else {
    gatherArray(comm, run->hits.triangle);
    gatherArray(comm, run->hits.t);
    gatherArray(comm, run->hits.u);
    gatherArray(comm, run->hits.v);
  }
  const double gather_seconds = gather_timer.seconds();
  const std::vector<double> per_rank = allgatherValue(comm, trace_seconds);
  const std::vector<uint64_t> hits_per_rank =
      allgatherValue(comm, run->stats["hits"].get<uint64_t>());
  if (!comm.root()) return run;
  uint64_t hit_count = 0;
  for (uint64_t h : hits_per_rank) hit_count += h;
  const double seconds = timer.seconds();
  std::vector<uint64_t> rays_per_rank;
  for (int r = 0; r < comm.size(); ++r) rays_per_rank.push_back(offsets[r + 1] - offsets[r]);
  nlohmann::json& st = run->stats;
  st["rays"] = total;
  st["hits"] = hit_count;
  st["ranks"] = comm.size();
  st["mpi"] = comm.describe();
  st["rays_per_rank"] = rays_per_rank;
  st["trace_seconds_per_rank"] = per_rank;
  st["scatter_seconds"] = scatter_seconds;
  st["gather_seconds"] = gather_seconds;
  // The whole distributed trace, from the scatter to the gathered answers.
  st["seconds"] = seconds;
  st["mrays_per_s"] = seconds > 0.0 ? double(total) / seconds * 1e-6 : 0.0;
  spdlog::info(
      "{} rays over {} ranks: {} {}; scatter {:.3f} s, trace {:.3f} s (slowest rank), "
      "gather {:.3f} s",
      total, comm.size(), hit_count, options.occlusion ? "occluded" : "hits", scatter_seconds,
      *std::max_element(per_rank.begin(), per_rank.end()), gather_seconds);
  return run;
}

}  // namespace penumbra
