// `penumbra trace`: the Ray Engine as a service (design doc sec. 4).
#include "penumbra/app/commands.h"
#include "penumbra/cluster/communicator.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/io/ray_file.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/methods/device.h"
#include "penumbra/methods/stats_file.h"
#include "penumbra/methods/trace.h"
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

namespace {

Status writeTraceOutputs(const TraceOptions& options, const TraceRun& run) {
  if (options.occlusion) {
    PENUMBRA_TRY(writeOcclusionFile(options.output, run.occluded));
  } else {
    PENUMBRA_TRY(writeHitFile(options.output, run.hits));
  }
  if (!options.stats.empty()) PENUMBRA_TRY(writeStatsFile(options.stats, run.stats));
  return {};
}

}  // namespace

namespace {

Status trace(const TraceOptions& options, const CommonOptions& common) {
  Communicator& comm = currentCommunicator();
  ReadyGate gate(comm);
  PENUMBRA_TRY(checkTraceOptions(options));
  PENUMBRA_TRY(checkOutputPath(options.output));
  if (!options.stats.empty()) PENUMBRA_TRY(checkOutputPath(options.stats));
  std::error_code ec;
  const auto ray_bytes = std::filesystem::file_size(options.rays, ec);
  if (!ec) {
    // Rays in SoA (32 B), hits (16 B), the file bytes and the output buffer (16 B); over several
    // ranks, rank 0 holds all of it and the others their share.
    const uint64_t count = uint64_t(ray_bytes) / 32;
    const uint64_t here = comm.root() ? count : shareOf(count, comm.rank(), comm.size()).size();
    PENUMBRA_TRY(checkMemory(here * 96, fmt::format("tracing {} rays", here)));
  }

  Expected<Scene> scene = loadScene(options.mesh);
  if (!scene) return scene.error();
  for (const std::string& w : scene->warnings) spdlog::warn("{}", w);
  if (!comm.distributed()) {
    Expected<RayBatch> rays = readRayFile(options.rays);
    if (!rays) return rays.error();
    Expected<TraceRun> run = traceScene(*scene, *rays, options, common.dry_run);
    if (!run) return run.error();
    if (common.dry_run) return {};
    return writeTraceOutputs(options, *run);
  }
  // Over several ranks: rank 0 reads the rays (the others may not see the file).
  RayBatch rays;
  if (comm.root()) {
    Expected<RayBatch> r = readRayFile(options.rays);
    if (!r) return r.error();
    rays = std::move(*r);
  }
  // The options and the device, on every rank, before they agree to start.
  if (Expected<TraceRun> ready = traceScene(*scene, RayBatch(), options, true); !ready) {
    return ready.error();
  }
  PENUMBRA_TRY(gate.open());
  if (common.dry_run) return {};
  Expected<TraceRun> run = traceOverRanks(comm, *scene, rays, options);
  if (!run) return run.error();
  if (!comm.root()) return {};
  return writeTraceOutputs(options, *run);
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
