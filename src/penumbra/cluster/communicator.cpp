#include "penumbra/cluster/communicator.h"

#include "penumbra/core/check.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>
#include <thread>

namespace penumbra {

namespace {

LocalCommunicator g_local;
bool g_this_rank_reports = false;
Communicator* g_current = nullptr;

std::vector<std::byte> copyOf(const void* data, size_t bytes) {
  std::vector<std::byte> out(bytes);
  if (bytes > 0) std::memcpy(out.data(), data, bytes);
  return out;
}

}  // namespace

void LocalCommunicator::send(int, int, const void*, size_t) {
  PENUMBRA_CHECK_MSG(false, "one process has no other rank to send to");
}

Communicator::Message LocalCommunicator::receive(int, int) {
  PENUMBRA_CHECK_MSG(false, "one process has no other rank to receive from");
  return {};
}

std::vector<std::byte> LocalCommunicator::gather(const void* data, size_t bytes, int,
                                                 std::vector<size_t>* counts) {
  if (counts) *counts = {bytes};
  return copyOf(data, bytes);
}

std::vector<std::byte> LocalCommunicator::allgather(const void* data, size_t bytes,
                                                    std::vector<size_t>* counts) {
  if (counts) *counts = {bytes};
  return copyOf(data, bytes);
}

std::vector<std::byte> LocalCommunicator::scatter(const void* data, std::span<const size_t> offsets,
                                                  int) {
  PENUMBRA_CHECK(offsets.size() == 2);
  return copyOf(static_cast<const std::byte*>(data) + offsets[0], offsets[1] - offsets[0]);
}

void LocalCommunicator::abort(int code) {
  std::_Exit(code);
}

Communicator& currentCommunicator() {
  return g_current ? *g_current : g_local;
}

CommunicatorScope::CommunicatorScope(Communicator& comm) : previous_(g_current) {
  g_current = &comm;
}

CommunicatorScope::~CommunicatorScope() {
  g_current = previous_;
}

int threadsPerRank(const Communicator& comm, int requested) {
  if (requested > 0) return requested;
  if (!comm.distributed()) return 0;
  const int cores = int(std::max(1u, std::thread::hardware_concurrency()));
  return std::max(1, cores / localRanks());
}

Expected<std::string> radiosityDeviceOverRanks(const Communicator& comm,
                                               const std::string& requested,
                                               const std::string& method) {
  if (!comm.distributed()) return requested;
  if (requested != "auto" && requested != "cpu") {
    return inputError("", "--device",
                      fmt::format("{} over {} ranks runs on the ranks' CPUs (its GPU solver works "
                                  "on one device); use --device cpu",
                                  method, comm.size()));
  }
  return std::string("cpu");
}

Share shareOf(uint64_t n, int rank, int size) {
  const uint64_t p = uint64_t(size), r = uint64_t(rank);
  const uint64_t base = n / p, extra = n % p;
  Share s;
  s.begin = r * base + std::min(r, extra);
  s.end = s.begin + base + (r < extra ? 1 : 0);
  return s;
}

Status agreeReady(Communicator& comm, const Status& mine) {
  if (!comm.distributed()) return mine;
  // Each rank's state: 0 ready, 1 input error, 2 run-time error.
  const int32_t state = mine.ok() ? 0 : mine.error().kind == ErrorKind::kInput ? 1 : 2;
  const std::vector<int32_t> all = allgatherValue(comm, state);
  for (int r = 0; r < comm.size(); ++r) {
    if (all[size_t(r)] == 0) continue;
    if (r == comm.rank()) {
      Error own = mine.error();
      own.report_on_this_rank = true;
      return own;
    }
    const ErrorKind kind = all[size_t(r)] == 1 ? ErrorKind::kInput : ErrorKind::kRuntime;
    return Error{
        kind, "", "",
        fmt::format("rank {} of {} could not start (its own message says why)", r, comm.size())};
  }
  return {};
}

ReadyGate::~ReadyGate() {
  if (opened_ || !comm_.distributed()) return;
  const Status agreed = agreeReady(comm_, Error{ErrorKind::kInput, "", "", "failed here"});
  if (!agreed.ok() && agreed.error().report_on_this_rank) g_this_rank_reports = true;
}

Status ReadyGate::open() {
  opened_ = true;
  const Status agreed = agreeReady(comm_, {});
  // From here on an error on this rank is its own (a GPU that failed here): it prints it.
  if (agreed.ok()) g_this_rank_reports = true;
  return agreed;
}

bool thisRankReports() {
  return g_this_rank_reports;
}

}  // namespace penumbra
