// An image over the ranks (docs/scaling.md): blocks of rows handed out on demand
// (cluster/block_dispatch.h); every rank renders the blocks it is given, rank 0 places them. The
// path tracer draws each sample from its pixel's own streams (raytrace/path_tracer.h:
// Determinism), so the image is bit-identical to one process's whatever rank renders a row.
#pragma once

#include "penumbra/cluster/block_dispatch.h"
#include "penumbra/cluster/communicator.h"
#include "penumbra/core/image.h"

#include <functional>
#include <span>

namespace penumbra {

struct DistributedRenderStats {
  int block_rows = 0;                     // rows per block
  uint64_t rays = 0;                      // every rank's rays (on every rank)
  std::vector<uint64_t> blocks_per_rank;  // on rank 0
  std::vector<uint64_t> rays_per_rank;    // on every rank
  uint64_t bytes_received = 0;            // on rank 0: pixels from the other ranks
};

// Rows per block for an image `height` rows high over `ranks` ranks: 8 blocks per rank where the
// rows allow (so that a slow rank holds back the end by at most an eighth of its share), one row
// at least (a block of fewer rows than a rank has threads renders its pixels in parallel:
// PathTracer::renderRows). A 2160-row frame keeps up to 270 ranks busy at 8 blocks each, and up
// to 2160 at one row each.
int rowBlockSize(int height, int ranks);

// Renders a width x height image: `render_rows(y0, y1, out)` renders rows [y0, y1) into `out`
// ((y1 - y0) x width) and returns its rays; it throws on failure (which ends the job).
// `on_rows(n)` on rank 0 when n more rows are in. Returns the image on rank 0, an empty one
// elsewhere. Collective.
Image renderOverRanks(
    Communicator& comm, int width, int height, int block_rows,
    const std::function<uint64_t(int y0, int y1, std::span<glm::vec3> out)>& render_rows,
    const std::function<void(int)>& on_rows, DistributedRenderStats* stats = nullptr);

}  // namespace penumbra
