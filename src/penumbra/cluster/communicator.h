// The processes one run is spread over (docs/scaling.md): MPI when the
// library was built with it and the program runs under mpirun (or a caller hands it an MPI
// communicator through the API), else one process. The methods are written against this
// interface only, so a build without MPI compiles and runs every one of them on one process, and
// the MPI calls live in one file (cluster/mpi_communicator.cpp).
//
// Conventions every distributed method keeps:
//  - Every rank loads the scene and parses the options itself (the same inputs give the same
//    scene everywhere); rank 0 (the root) reads the large inputs that are not the scene (ray
//    files), writes every output and prints the log; the others stay quiet unless they fail.
//  - Before the work, the ranks agree that every one of them is ready (agreeReady): an error on
//    one rank stops them all, reported once, with no collective left waiting.
//  - Reductions are made in rank order on every rank (allgather, then a fixed-order sum), so
//    their results do not depend on timing and match one process where the method allows it.
//  - A failure on one rank during the work ends the job (MPI's default: mpirun stops every rank
//    when one exits abnormally), never a hang.
#pragma once

#include "penumbra/core/expected.h"

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace penumbra {

// A communication failure (an MPI call that returned an error).
class ClusterError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Communicator {
 public:
  static constexpr int kAnySource = -1;

  virtual ~Communicator() = default;

  virtual int rank() const = 0;
  virtual int size() const = 0;
  bool root() const { return rank() == 0; }
  bool distributed() const { return size() > 1; }
  // Whether a second thread may make calls while the first one computes (MPI_THREAD_SERIALIZED
  // or better): rank 0 then serves block requests from a thread of its own (cluster/
  // block_dispatch.h); otherwise blocks are assigned statically.
  virtual bool threadsMayCall() const = 0;
  // What this is, for logs and statistics ("Open MPI v4.1.4", "one process").
  virtual std::string describe() const = 0;

  virtual void barrier() = 0;
  // Point to point, any size; `tag` < 1000 (the layer keeps higher tags for itself).
  virtual void send(int dest, int tag, const void* data, size_t bytes) = 0;
  struct Message {
    int source = 0;
    std::vector<std::byte> bytes;
  };
  // The next message with `tag` from `source` (kAnySource: any rank). Waits without spinning a
  // core (a short sleep between polls), so rank 0's dispatch thread leaves the cores to the work.
  virtual Message receive(int source, int tag) = 0;
  // Root's `bytes` bytes at `data` to every rank (the others' buffers must have the size).
  virtual void broadcast(void* data, size_t bytes, int root) = 0;
  // Every rank's bytes, concatenated in rank order; `counts` (if given) gets each rank's byte
  // count. gather: on `root` only (empty elsewhere); allgather: on every rank.
  virtual std::vector<std::byte> gather(const void* data, size_t bytes, int root,
                                        std::vector<size_t>* counts) = 0;
  virtual std::vector<std::byte> allgather(const void* data, size_t bytes,
                                           std::vector<size_t>* counts) = 0;
  // Root's buffer split at `offsets` (size() + 1 byte offsets, given on root only): rank r gets
  // [offsets[r], offsets[r + 1]).
  virtual std::vector<std::byte> scatter(const void* data, std::span<const size_t> offsets,
                                         int root) = 0;
  // Personalised exchange: `to[r]` goes to rank r; returns what each rank sent this one, by
  // source rank (to[rank()] comes back as it is).
  virtual std::vector<std::vector<std::byte>> alltoall(std::vector<std::vector<std::byte>> to) = 0;
  // Ends every rank of the job at once with `code` (a failure that the others cannot learn of
  // through the work's own messages).
  [[noreturn]] virtual void abort(int code) = 0;
};

// One process: every collective is a copy.
class LocalCommunicator final : public Communicator {
 public:
  int rank() const override { return 0; }
  int size() const override { return 1; }
  bool threadsMayCall() const override { return true; }
  std::string describe() const override { return "one process"; }
  void barrier() override {}
  void send(int dest, int tag, const void* data, size_t bytes) override;
  Message receive(int source, int tag) override;
  void broadcast(void*, size_t, int) override {}
  std::vector<std::byte> gather(const void* data, size_t bytes, int root,
                                std::vector<size_t>* counts) override;
  std::vector<std::byte> allgather(const void* data, size_t bytes,
                                   std::vector<size_t>* counts) override;
  std::vector<std::byte> scatter(const void* data, std::span<const size_t> offsets,
                                 int root) override;
  std::vector<std::vector<std::byte>> alltoall(std::vector<std::vector<std::byte>> to) override {
    return to;
  }
  [[noreturn]] void abort(int code) override;
};

// The communicator the commands run over: the API's (a CommunicatorScope), else the MPI job the
// CLI joined (joinMpiJob), else one process.
Communicator& currentCommunicator();

// Makes `comm` current for as long as the scope lives (the API's calls with a communicator).
class CommunicatorScope {
 public:
  explicit CommunicatorScope(Communicator& comm);
  ~CommunicatorScope();
  CommunicatorScope(const CommunicatorScope&) = delete;
  CommunicatorScope& operator=(const CommunicatorScope&) = delete;

 private:
  Communicator* previous_;
};

// --- MPI (cluster/mpi_communicator.cpp; without MPI in the build, the stubs say so) ---

// Whether the library was built with MPI.
bool mpiBuilt();
// "Open MPI v4.1.4, ..." (empty without MPI).
std::string mpiLibraryVersion();
// Whether this process was started by an MPI launcher (mpirun, srun with PMI/PMIx): its
// environment says so. A process started otherwise never initialises MPI.
bool launchedByMpiLauncher();
// Ranks of this job on this machine (OMPI_COMM_WORLD_LOCAL_SIZE), 1 when unknown: the default
// thread count divides the cores among them.
int localRanks();
// Processes the launcher started (OMPI_COMM_WORLD_SIZE, PMI_SIZE), 1 when unknown.
int launcherWorldSize();
// Worker threads for this rank: `requested` when given (> 0); over several ranks, the machine's
// cores divided among the ranks on it (at least 1); else 0 (every core).
int threadsPerRank(const Communicator& comm, int requested);

// The CLI's MPI job: initialises MPI (MPI_Init_thread, asking for MPI_THREAD_SERIALIZED) when
// launched by an MPI launcher and makes MPI_COMM_WORLD current; finalises it on destruction.
// Without a launcher, or without MPI in the build, it does nothing and the run is one process.
class MpiJob {
 public:
  MpiJob(int* argc, char*** argv);
  ~MpiJob();
  MpiJob(const MpiJob&) = delete;
  MpiJob& operator=(const MpiJob&) = delete;
  // The world (null when the run is one process).
  Communicator* world() const { return world_.get(); }
  // A run that failed ends without MPI_Finalize (which waits for every rank): the launcher sees
  // the non-zero exit and stops the other ranks.
  void skipFinalize() { finalize_ = false; }

 private:
  std::unique_ptr<Communicator> world_;
  bool finalize_ = false;
};

// A communicator over an MPI communicator given by its Fortran handle (MPI_Comm_c2f), which the
// caller keeps alive and has initialised with MPI_Init_thread. Errors: MPI not in the build, MPI
// not initialised.
Expected<std::unique_ptr<Communicator>> wrapMpiCommunicator(int64_t fortran_handle);

// --- Helpers on top of the interface ---

// Every rank's status before distributed work starts: each rank passes its own, and all agree:
// ok when every rank is ok; else the lowest failing rank returns its own error, marked
// report_on_this_rank (rank 0 prints its errors anyway), and the others an error of the same
// kind that names that rank. So a failure on one rank stops them all before any collective of
// the work, and is printed once (twice when it is not rank 0's: by the rank and by rank 0).
Status agreeReady(Communicator& comm, const Status& mine);

// agreeReady for a command with many early returns: made at its start, opened (open() returns
// the agreement) just before the distributed work. A rank that returns before opening it joins
// the agreement from the destructor as failed, and, if it is the lowest failing rank,
// thisRankReports() then tells reportError to print its error here (with its rank). No-op on
// one process.
class ReadyGate {
 public:
  explicit ReadyGate(Communicator& comm) : comm_(comm) {}
  ~ReadyGate();
  ReadyGate(const ReadyGate&) = delete;
  ReadyGate& operator=(const ReadyGate&) = delete;
  Status open();

 private:
  Communicator& comm_;
  bool opened_ = false;
};
// Whether this rank (not rank 0) prints its errors: set by a ReadyGate that failed here first, or
// that opened (an error after the ranks agreed to start is this rank's own).
bool thisRankReports();

template <typename T>
std::vector<T> fromBytes(const std::vector<std::byte>& bytes) {
  static_assert(std::is_trivially_copyable_v<T>);
  std::vector<T> out(bytes.size() / sizeof(T));
  if (!out.empty()) std::memcpy(out.data(), bytes.data(), out.size() * sizeof(T));
  return out;
}

// Every rank's values, in rank order, on every rank (`counts`: each rank's count).
template <typename T>
std::vector<T> allgatherValues(Communicator& comm, std::span<const T> mine,
                               std::vector<size_t>* counts = nullptr) {
  static_assert(std::is_trivially_copyable_v<T>);
  std::vector<size_t> bytes;
  std::vector<T> out =
      fromBytes<T>(comm.allgather(mine.data(), mine.size_bytes(), counts ? &bytes : nullptr));
  if (counts) {
    counts->clear();
    for (size_t b : bytes) counts->push_back(b / sizeof(T));
  }
  return out;
}
template <typename T>
std::vector<T> allgatherValue(Communicator& comm, const T& mine) {
  return allgatherValues<T>(comm, std::span<const T>(&mine, 1));
}
// The same on `root` only.
template <typename T>
std::vector<T> gatherValues(Communicator& comm, std::span<const T> mine, int root,
                            std::vector<size_t>* counts = nullptr) {
  static_assert(std::is_trivially_copyable_v<T>);
  std::vector<size_t> bytes;
  std::vector<T> out =
      fromBytes<T>(comm.gather(mine.data(), mine.size_bytes(), root, counts ? &bytes : nullptr));
  if (counts) {
    counts->clear();
    for (size_t b : bytes) counts->push_back(b / sizeof(T));
  }
  return out;
}
// Root's value on every rank.
template <typename T>
T broadcastValue(Communicator& comm, T value, int root = 0) {
  static_assert(std::is_trivially_copyable_v<T>);
  comm.broadcast(&value, sizeof(T), root);
  return value;
}
// Sum over the ranks of each entry, added in rank order (the same bits on every rank).
template <typename T>
std::vector<T> allreduceSum(Communicator& comm, std::span<const T> mine) {
  const std::vector<T> all = allgatherValues(comm, mine);
  std::vector<T> sum(mine.size(), T(0));
  for (size_t r = 0; r < size_t(comm.size()); ++r) {
    for (size_t i = 0; i < mine.size(); ++i) sum[i] += all[r * mine.size() + i];
  }
  return sum;
}
template <typename T>
T allreduceSum(Communicator& comm, T mine) {
  return allreduceSum(comm, std::span<const T>(&mine, 1))[0];
}

// The --device a radiosity method (`method`: its name for the message) runs on: `requested` on
// one process; over several ranks the CPU (the GPU solvers work on one device), refusing an
// explicit gpu or hybrid.
Expected<std::string> radiosityDeviceOverRanks(const Communicator& comm,
                                               const std::string& requested,
                                               const std::string& method);

// [begin, end) of rank r's share of n items split as evenly as the ranks allow (the first
// n % size ranks take one more).
struct Share {
  uint64_t begin = 0, end = 0;
  uint64_t size() const { return end - begin; }
};
Share shareOf(uint64_t n, int rank, int size);

}  // namespace penumbra
