// `penumbra trace` without its files: a scene's triangles and a batch of rays in, the answers and
// the statistics out, on the device the options name. The CLI (trace_command.cpp) and the
// library's API (penumbra.h: trace) both run it.
#pragma once

#include "penumbra/cluster/communicator.h"
#include "penumbra/core/expected.h"
#include "penumbra/kernels/ray.h"
#include "penumbra/scene/scene.h"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace penumbra {

// `penumbra trace`'s options.
struct TraceOptions {
  std::string mesh;
  // --device hybrid: GPU cells hold t_min..t_max triangles; r_min rays per GPU pass (sec. 6.2);
  // each cell's ray cache holds cache_rays rays (sec. 5.3; unset: 4 r_min).
  uint32_t t_min = 64, t_max = 1024, r_min = 256;
  std::optional<uint32_t> cache_rays;
  std::string rays;
  std::string output;
  std::string stats;
  std::string device = "auto";
  bool occlusion = false;  // any hit: one byte per ray instead of closest hits
};

struct TraceRun {
  HitBatch hits;                  // closest hits (empty with --occlusion)
  std::vector<uint8_t> occluded;  // --occlusion: 1 where occluded (else empty)
  nlohmann::json stats;           // what --stats writes
};

// --device, --t-min / --t-max, --cache-rays / --r-min.
Status checkTraceOptions(const TraceOptions& options);
// Checks the options, makes the device, builds its Ray Engine over the scene's triangles
// (flattenScene numbering) and traces; `dry_run` stops before the build.
Expected<TraceRun> traceScene(const Scene& scene, const RayBatch& rays, const TraceOptions& options,
                              bool dry_run);

// traceScene over the ranks of `comm` (collective): rank 0's rays scattered in equal shares,
// traced on every rank, the answers gathered on rank 0 in the rays' order (one process's, bit
// for bit), with the statistics of the whole. A rank whose device fails ends the job.
Expected<TraceRun> traceOverRanks(Communicator& comm, const Scene& scene, const RayBatch& rays,
                                  const TraceOptions& options);

}  // namespace penumbra
