// `penumbra trace` without its files: a scene's triangles and a batch of rays in, the answers and
// the statistics out, on the device the options name. The CLI (trace_command.cpp) and the
// library's API (penumbra.h: trace) both run it.
#pragma once

#include "penumbra/app/commands.h"
#include "penumbra/cluster/communicator.h"
#include "penumbra/kernels/ray.h"
#include "penumbra/scene/scene.h"

#include <cstdint>
#include <vector>

namespace penumbra {

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
