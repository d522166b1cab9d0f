#include "penumbra/cluster/block_dispatch.h"

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <mutex>
#include <thread>

namespace penumbra {

namespace {

// A rank that cannot finish its part ends the job: the others would wait for it forever.
[[noreturn]] void endJob(Communicator& comm, const char* what) {
  std::fprintf(stderr, "penumbra: error: rank %d of %d: %s\n", comm.rank(), comm.size(), what);
  std::fflush(stderr);
  comm.abort(1);
  std::_Exit(1);  // abort() does not return; this says so to the compiler
}

template <typename F>
auto orEndJob(Communicator& comm, F&& f) {
  try {
    return f();
  } catch (const std::exception& e) {
    endJob(comm, e.what());
  }
}

// A message: the block's number (-1: none, a first request), then its result.
std::vector<std::byte> withHeader(int64_t block, std::span<const std::byte> payload) {
  std::vector<std::byte> out(sizeof(int64_t) + payload.size());
  std::memcpy(out.data(), &block, sizeof(int64_t));
  if (!payload.empty()) std::memcpy(out.data() + sizeof(int64_t), payload.data(), payload.size());
  return out;
}

int64_t headerOf(const std::vector<std::byte>& message) {
  int64_t block = -1;
  if (message.size() >= sizeof(int64_t)) std::memcpy(&block, message.data(), sizeof(int64_t));
  return block;
}

// Without threads in the MPI library: block b on rank b mod size, gathered at the end, each
// result behind its number and length.
void dispatchStatically(Communicator& comm, uint64_t count,
                        const std::function<std::vector<std::byte>(uint64_t)>& work,
                        const std::function<void(uint64_t, std::span<const std::byte>)>& deliver,
                        BlockDispatchStats* stats) {
  std::vector<std::byte> mine;
  for (uint64_t b = uint64_t(comm.rank()); b < count; b += uint64_t(comm.size())) {
    const std::vector<std::byte> result = orEndJob(comm, [&] { return work(b); });
    const uint64_t head[2] = {b, result.size()};
    const size_t at = mine.size();
    mine.resize(at + sizeof(head) + result.size());
    std::memcpy(mine.data() + at, head, sizeof(head));
    if (!result.empty()) std::memcpy(mine.data() + at + sizeof(head), result.data(), result.size());
  }
  std::vector<size_t> counts;
  const std::vector<std::byte> all = comm.gather(mine.data(), mine.size(), 0, &counts);
  if (!comm.root()) return;
  if (stats) stats->blocks_per_rank.assign(size_t(comm.size()), 0);
  size_t at = 0;
  for (size_t r = 0; r < counts.size(); ++r) {
    const size_t end = at + counts[r];
    while (at < end) {
      uint64_t head[2];
      std::memcpy(head, all.data() + at, sizeof(head));
      at += sizeof(head);
      deliver(head[0], std::span<const std::byte>(all.data() + at, head[1]));
      at += head[1];
      if (stats) {
        ++stats->blocks_per_rank[r];
        if (r > 0) stats->bytes_received += head[1];
      }
    }
  }
}

}  // namespace

void dispatchBlocks(Communicator& comm, uint64_t count, int tag,
                    const std::function<std::vector<std::byte>(uint64_t)>& work,
                    const std::function<void(uint64_t, std::span<const std::byte>)>& deliver,
                    BlockDispatchStats* stats) {
  if (stats) *stats = BlockDispatchStats{};
  if (!comm.distributed()) {
    for (uint64_t b = 0; b < count; ++b) deliver(b, work(b));
    if (stats) stats->blocks_per_rank = {count};
    return;
  }
  if (!comm.threadsMayCall()) {
    dispatchStatically(comm, count, work, deliver, stats);
    return;
  }
  if (!comm.root()) {
    std::vector<std::byte> message = withHeader(-1, {});
    for (;;) {
      const int64_t block = orEndJob(comm, [&] {
        comm.send(0, tag, message.data(), message.size());
        return headerOf(comm.receive(0, tag).bytes);
      });
      if (block < 0) return;
      const std::vector<std::byte> result = orEndJob(comm, [&] { return work(uint64_t(block)); });
      message = withHeader(block, result);
    }
  }

  // Rank 0: its own blocks on this thread, the others' requests on a second one. The counter is
  // the one queue both take from.
  std::atomic<uint64_t> next{0};
  std::mutex deliver_mutex;
  std::vector<uint64_t> per_rank(size_t(comm.size()), 0);
  uint64_t bytes_received = 0;
  std::thread server([&] {
    orEndJob(comm, [&] {
      int finished = 0;
      while (finished < comm.size() - 1) {
        const Communicator::Message m = comm.receive(Communicator::kAnySource, tag);
        const int64_t done = headerOf(m.bytes);
        if (done >= 0) {
          const std::span<const std::byte> result(m.bytes.data() + sizeof(int64_t),
                                                  m.bytes.size() - sizeof(int64_t));
          const std::lock_guard<std::mutex> lock(deliver_mutex);
          deliver(uint64_t(done), result);
          ++per_rank[size_t(m.source)];
          bytes_received += result.size();
        }
        const uint64_t b = next.fetch_add(1);
        const int64_t reply = b < count ? int64_t(b) : -1;
        if (reply < 0) ++finished;
        comm.send(m.source, tag, &reply, sizeof(reply));
      }
      return 0;
    });
  });
  for (;;) {
    const uint64_t b = next.fetch_add(1);
    if (b >= count) break;
    const std::vector<std::byte> result = orEndJob(comm, [&] { return work(b); });
    const std::lock_guard<std::mutex> lock(deliver_mutex);
    deliver(b, result);
    ++per_rank[0];
  }
  server.join();
  if (stats) {
    stats->blocks_per_rank = per_rank;
    stats->bytes_received = bytes_received;
  }
}

}  // namespace penumbra
