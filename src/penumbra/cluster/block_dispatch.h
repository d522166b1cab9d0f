// Dynamic load balancing over the ranks (docs/scaling.md): blocks of work, numbered 0 .. count -
// 1, handed out on demand, so a rank on a faster machine or with cheaper blocks (an empty sky
// against a glass sculpture) takes more of them. Rank 0 works on blocks too, and serves the other
// ranks' requests from a thread of its own; each other rank sends a block's result together with
// its request for the next one (one message each way per block).
//
// The results are what each block computes from its number alone, so which rank computed a block
// changes nothing in the answer: rank 0 places every block's result where it belongs.
//
// Where the MPI library gives no thread support (threadsMayCall() false), blocks are dealt out
// statically instead (block b to rank b mod size) and gathered at the end: the same results.
#pragma once

#include "penumbra/cluster/communicator.h"

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

namespace penumbra {

struct BlockDispatchStats {
  std::vector<uint64_t> blocks_per_rank;  // on rank 0: blocks each rank computed
  uint64_t bytes_received = 0;            // on rank 0: result bytes from the other ranks
};

// Computes every block on some rank: `work(block)` returns its result; on rank 0, `deliver(block,
// result)` receives each block's result (rank 0's own and the others'), one call at a time,
// possibly from the dispatch thread. Collective: every rank calls it with the same count and
// tag. An exception from `work` on any rank ends the job (the others cannot finish without it).
void dispatchBlocks(Communicator& comm, uint64_t count, int tag,
                    const std::function<std::vector<std::byte>(uint64_t)>& work,
                    const std::function<void(uint64_t, std::span<const std::byte>)>& deliver,
                    BlockDispatchStats* stats = nullptr);

}  // namespace penumbra
