// The Communicator over MPI (cluster/communicator.h): the one file that calls MPI. Built when
// CMake found MPI (PENUMBRA_WITH_MPI); otherwise the stubs at the end say that the build has none.
#include "penumbra/cluster/communicator.h"

#include <fmt/format.h>

#include <chrono>
#include <cstdlib>
#include <thread>

#if PENUMBRA_WITH_MPI
#include <mpi.h>
#endif

namespace penumbra {

bool launchedByMpiLauncher() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE"}) {
    if (std::getenv(name)) return true;
  }
  return false;
}

int localRanks() {
  for (const char* name :
       {"OMPI_COMM_WORLD_LOCAL_SIZE", "MPI_LOCALNRANKS", "SLURM_NTASKS_PER_NODE"}) {
    if (const char* v = std::getenv(name)) {
      const int n = std::atoi(v);
      if (n > 0) return n;
    }
  }
  return 1;
}

int launcherWorldSize() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE"}) {
    if (const char* v = std::getenv(name)) {
      const int n = std::atoi(v);
      if (n > 0) return n;
    }
  }
  return 1;
}

#if PENUMBRA_WITH_MPI

namespace {

// Messages and collectives move at most this many bytes per MPI call (MPI counts are int).
constexpr size_t kChunk = size_t(1) << 30;

void check(int code, const char* call) {
  if (code == MPI_SUCCESS) return;
  char text[MPI_MAX_ERROR_STRING];
  int length = 0;
  MPI_Error_string(code, text, &length);
  throw ClusterError(fmt::format("{} failed: {}", call, std::string(text, size_t(length))));
}

class MpiCommunicator final : public Communicator {
 public:
  explicit MpiCommunicator(MPI_Comm comm) : comm_(comm) {
    check(MPI_Comm_rank(comm_, &rank_), "MPI_Comm_rank");
    check(MPI_Comm_size(comm_, &size_), "MPI_Comm_size");
    int provided = MPI_THREAD_SINGLE;
    check(MPI_Query_thread(&provided), "MPI_Query_thread");
    threads_ = provided >= MPI_THREAD_SERIALIZED;
    // Errors come back as codes (ClusterError) rather than aborting inside MPI.
    check(MPI_Comm_set_errhandler(comm_, MPI_ERRORS_RETURN), "MPI_Comm_set_errhandler");
  }

  int rank() const override { return rank_; }
  int size() const override { return size_; }
  bool threadsMayCall() const override { return threads_; }
  std::string describe() const override {
    return fmt::format("MPI, {} ranks ({})", size_, mpiLibraryVersion());
  }

  void barrier() override { check(MPI_Barrier(comm_), "MPI_Barrier"); }

  // A message of any size: pieces of kChunk bytes, then a last one shorter than kChunk (maybe
  // empty), which tells the receiver it is the end. Messages between two ranks with one tag
  // arrive in order (MPI's non-overtaking rule).
  void send(int dest, int tag, const void* data, size_t bytes) override {
    const char* p = static_cast<const char*>(data);
    for (;;) {
      const size_t n = std::min(bytes, kChunk);
      check(MPI_Send(p, int(n), MPI_BYTE, dest, tag, comm_), "MPI_Send");
      if (n < kChunk) return;
      p += n;
      bytes -= n;
    }
  }

  Message receive(int source, int tag) override {
    Message m;
    int from = source == kAnySource ? MPI_ANY_SOURCE : source;
    for (;;) {
      MPI_Status status;
      waitFor(from, tag, &status);
      from = status.MPI_SOURCE;
      int count = 0;
      check(MPI_Get_count(&status, MPI_BYTE, &count), "MPI_Get_count");
      const size_t at = m.bytes.size();
      m.bytes.resize(at + size_t(count));
      check(MPI_Recv(m.bytes.data() + at, count, MPI_BYTE, from, tag, comm_, MPI_STATUS_IGNORE),
            "MPI_Recv");
      if (size_t(count) < kChunk) break;
    }
    m.source = from;
    return m;
  }

  void broadcast(void* data, size_t bytes, int root) override {
    char* p = static_cast<char*>(data);
    for (size_t at = 0; at < bytes; at += kChunk) {
      const size_t n = std::min(kChunk, bytes - at);
      check(MPI_Bcast(p + at, int(n), MPI_BYTE, root, comm_), "MPI_Bcast");
    }
  }

  std::vector<std::byte> gather(const void* data, size_t bytes, int root,
                                std::vector<size_t>* counts) override {
    const std::vector<size_t> sizes = byteCounts(bytes);
    if (counts) *counts = rank_ == root ? sizes : std::vector<size_t>{};
    std::vector<std::byte> out;
    size_t total = 0;
    for (size_t s : sizes) total += s;
    if (rank_ == root) out.resize(total);
    if (fitsOneCall(sizes)) {
      std::vector<int> c, d;
      offsets(sizes, c, d);
      check(MPI_Gatherv(data, int(bytes), MPI_BYTE, out.data(), c.data(), d.data(), MPI_BYTE, root,
                        comm_),
            "MPI_Gatherv");
      return out;
    }
    // Large: point to point, rank by rank.
    if (rank_ != root) {
      send(root, kGatherTag, data, bytes);
      return out;
    }
    size_t at = 0;
    for (int r = 0; r < size_; ++r) {
      if (r == root) {
        if (bytes > 0) std::memcpy(out.data() + at, data, bytes);
      } else {
        const Message m = receive(r, kGatherTag);
        if (!m.bytes.empty()) std::memcpy(out.data() + at, m.bytes.data(), m.bytes.size());
      }
      at += sizes[size_t(r)];
    }
    return out;
  }

  std::vector<std::byte> allgather(const void* data, size_t bytes,
                                   std::vector<size_t>* counts) override {
    const std::vector<size_t> sizes = byteCounts(bytes);
    if (counts) *counts = sizes;
    size_t total = 0;
    for (size_t s : sizes) total += s;
    std::vector<std::byte> out(total);
    if (fitsOneCall(sizes)) {
      std::vector<int> c, d;
      offsets(sizes, c, d);
      check(MPI_Allgatherv(data, int(bytes), MPI_BYTE, out.data(), c.data(), d.data(), MPI_BYTE,
                           comm_),
            "MPI_Allgatherv");
      return out;
    }
    out = gather(data, bytes, 0, nullptr);
    out.resize(total);
    broadcast(out.data(), total, 0);
    return out;
  }

  std::vector<std::byte> scatter(const void* data, std::span<const size_t> offsets_in,
                                 int root) override {
    std::vector<uint64_t> at(static_cast<size_t>(size_) + 1, 0);
    if (rank_ == root) {
      for (size_t r = 0; r < at.size(); ++r) at[r] = offsets_in[r];
    }
    broadcast(at.data(), at.size() * sizeof(uint64_t), root);
    std::vector<size_t> sizes(static_cast<size_t>(size_));
    for (size_t r = 0; r < sizes.size(); ++r) sizes[r] = size_t(at[r + 1] - at[r]);
    std::vector<std::byte> out(sizes[size_t(rank_)]);
    if (fitsOneCall(sizes) && at.back() - at.front() < kChunk) {
      std::vector<int> c(static_cast<size_t>(size_)), d(static_cast<size_t>(size_));
      for (size_t r = 0; r < sizes.size(); ++r) c[r] = int(sizes[r]), d[r] = int(at[r] - at[0]);
      const char* base = rank_ == root ? static_cast<const char*>(data) + at[0] : nullptr;
      check(MPI_Scatterv(base, c.data(), d.data(), MPI_BYTE, out.data(), int(out.size()), MPI_BYTE,
                         root, comm_),
            "MPI_Scatterv");
      return out;
    }
    if (rank_ == root) {
      const char* base = static_cast<const char*>(data);
      for (int r = 0; r < size_; ++r) {
        if (r == root) {
          if (!out.empty()) std::memcpy(out.data(), base + at[size_t(r)], out.size());
        } else {
          send(r, kScatterTag, base + at[size_t(r)], sizes[size_t(r)]);
        }
      }
    } else {
      out = receive(root, kScatterTag).bytes;
    }
    return out;
  }

  // Counts first, then a pairwise schedule (step k: send to rank + k, receive from rank - k) in
  // pieces of at most kChunk bytes each way.
  std::vector<std::vector<std::byte>> alltoall(std::vector<std::vector<std::byte>> to) override {
    std::vector<uint64_t> send_counts(static_cast<size_t>(size_)),
        recv_counts(static_cast<size_t>(size_));
    for (size_t r = 0; r < send_counts.size(); ++r) send_counts[r] = to[r].size();
    check(MPI_Alltoall(send_counts.data(), 1, MPI_UINT64_T, recv_counts.data(), 1, MPI_UINT64_T,
                       comm_),
          "MPI_Alltoall");
    std::vector<std::vector<std::byte>> from(static_cast<size_t>(size_));
    from[size_t(rank_)] = std::move(to[size_t(rank_)]);
    for (int k = 1; k < size_; ++k) {
      const int dest = (rank_ + k) % size_, src = (rank_ - k + size_) % size_;
      const std::vector<std::byte>& out = to[size_t(dest)];
      std::vector<std::byte>& in = from[size_t(src)];
      in.resize(recv_counts[size_t(src)]);
      const size_t steps =
          std::max<size_t>(1, (std::max(out.size(), in.size()) + kChunk - 1) / kChunk);
      for (size_t step = 0; step < steps; ++step) {
        const size_t at = step * kChunk;
        const size_t ns = at < out.size() ? std::min(kChunk, out.size() - at) : 0;
        const size_t nr = at < in.size() ? std::min(kChunk, in.size() - at) : 0;
        check(MPI_Sendrecv(out.data() + (ns ? at : 0), int(ns), MPI_BYTE, dest, kAlltoallTag,
                           in.data() + (nr ? at : 0), int(nr), MPI_BYTE, src, kAlltoallTag, comm_,
                           MPI_STATUS_IGNORE),
              "MPI_Sendrecv");
      }
      std::vector<std::byte>().swap(to[size_t(dest)]);  // sent: its memory goes back at once
    }
    return from;
  }

  void abort(int code) override {
    MPI_Abort(comm_, code);
    std::_Exit(code);
  }

 private:
  static constexpr int kGatherTag = 1001, kScatterTag = 1002, kAlltoallTag = 1003;

  // Polls for a message, sleeping between polls once the first few find nothing: a blocking
  // receive in Open MPI spins a core, which on rank 0 would take it from the work.
  void waitFor(int source, int tag, MPI_Status* status) {
    int sleep_us = 0;
    for (;;) {
      int flag = 0;
      check(MPI_Iprobe(source, tag, comm_, &flag, status), "MPI_Iprobe");
      if (flag) return;
      if (sleep_us > 0) std::this_thread::sleep_for(std::chrono::microseconds(sleep_us));
      sleep_us = std::min(sleep_us * 2 + 1, 1000);
    }
  }

  std::vector<size_t> byteCounts(size_t bytes) {
    const uint64_t mine = bytes;
    std::vector<uint64_t> all(static_cast<size_t>(size_));
    check(MPI_Allgather(&mine, 1, MPI_UINT64_T, all.data(), 1, MPI_UINT64_T, comm_),
          "MPI_Allgather");
    return std::vector<size_t>(all.begin(), all.end());
  }
  static bool fitsOneCall(const std::vector<size_t>& sizes) {
    size_t total = 0;
    for (size_t s : sizes) total += s;
    return total < kChunk;
  }
  static void offsets(const std::vector<size_t>& sizes, std::vector<int>& counts,
                      std::vector<int>& displs) {
    counts.resize(sizes.size());
    displs.resize(sizes.size());
    int at = 0;
    for (size_t r = 0; r < sizes.size(); ++r) {
      counts[r] = int(sizes[r]);
      displs[r] = at;
      at += counts[r];
    }
  }

  MPI_Comm comm_;
  int rank_ = 0, size_ = 1;
  bool threads_ = false;
};

}  // namespace

bool mpiBuilt() {
  return true;
}

std::string mpiLibraryVersion() {
  char text[MPI_MAX_LIBRARY_VERSION_STRING];
  int length = 0;
  MPI_Get_library_version(text, &length);
  std::string s(text, size_t(length));
  // Open MPI's string goes on with its repository and date: the first part says enough.
  if (const size_t comma = s.find(','); comma != std::string::npos) s.resize(comma);
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s;
}

MpiJob::MpiJob(int* argc, char*** argv) {
  if (!launchedByMpiLauncher()) return;
  int initialized = 0;
  MPI_Initialized(&initialized);
  if (initialized) return;
  int provided = MPI_THREAD_SINGLE;
  if (MPI_Init_thread(argc, argv, MPI_THREAD_SERIALIZED, &provided) != MPI_SUCCESS) return;
  finalize_ = true;
  world_ = std::make_unique<MpiCommunicator>(MPI_COMM_WORLD);
}

MpiJob::~MpiJob() {
  world_.reset();
  if (finalize_) MPI_Finalize();
}

Expected<std::unique_ptr<Communicator>> wrapMpiCommunicator(int64_t fortran_handle) {
  int initialized = 0, finalized = 0;
  MPI_Initialized(&initialized);
  MPI_Finalized(&finalized);
  if (!initialized || finalized) {
    return inputError("", "communicator", "MPI is not initialised (call MPI_Init_thread first)");
  }
  const MPI_Comm comm = MPI_Comm_f2c(MPI_Fint(fortran_handle));
  if (comm == MPI_COMM_NULL) return inputError("", "communicator", "MPI_COMM_NULL");
  try {
    return std::unique_ptr<Communicator>(std::make_unique<MpiCommunicator>(comm));
  } catch (const ClusterError& e) {
    return inputError("", "communicator", e.what());
  }
}

#else  // no MPI in the build

bool mpiBuilt() {
  return false;
}

std::string mpiLibraryVersion() {
  return {};
}

MpiJob::MpiJob(int*, char***) {}
MpiJob::~MpiJob() = default;

Expected<std::unique_ptr<Communicator>> wrapMpiCommunicator(int64_t) {
  return inputError("", "communicator",
                    "this build of penumbra has no MPI (configure with libopenmpi-dev installed)");
}

#endif

}  // namespace penumbra
