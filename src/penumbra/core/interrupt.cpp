#include "penumbra/core/interrupt.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstring>

namespace penumbra {

namespace {

volatile std::sig_atomic_t g_scope = 0;      // an InterruptScope is alive
volatile std::sig_atomic_t g_requested = 0;  // the signal that asked to stop, 0 if none
std::atomic<bool> g_keep_requests{false};
volatile std::sig_atomic_t g_distributed = 0;  // SIGINT / SIGTERM always end the process
char g_end_message[256] = {};
std::atomic<size_t> g_end_message_length{0};  // 0: end without a message

// The cleanup registry: fixed slots, so the handler reads without allocating. A slot's state is
// written after its path, and cleared before the path is reused.
constexpr int kSlots = 128;
constexpr size_t kPathBytes = 1024;
struct Slot {
  volatile std::sig_atomic_t state = 0;  // 0 free, 1 file, 2 directory
  unsigned long order = 0;               // registration order (directories: latest first)
  char path[kPathBytes] = {};
};
Slot g_slots[kSlots];
std::atomic<bool> g_slot_busy[kSlots];
std::atomic<unsigned long> g_order{0};

void removeRegistered() {
  for (Slot& s : g_slots) {
    if (s.state == 1) ::unlink(s.path);
  }
  // Directories, the most recently made first (a parent after its children).
  for (;;) {
    Slot* latest = nullptr;
    for (Slot& s : g_slots) {
      if (s.state == 2 && (!latest || s.order > latest->order)) latest = &s;
    }
    if (!latest) break;
    ::rmdir(latest->path);
    latest->state = 0;
  }
}

extern "C" void onSignal(int sig) {
  if (g_distributed && sig != SIGUSR1) {
    // Only async-signal-safe calls: write(2) of a message made in advance.
    if (g_end_message_length > 0) {
      [[maybe_unused]] const ssize_t n = ::write(2, g_end_message, g_end_message_length);
    }
    removeRegistered();
    std::signal(sig, SIG_DFL);
    std::raise(sig);
    return;
  }
  if (g_distributed) {
    // SIGUSR1: a request to stop cleanly whenever it comes (a rank may not have reached its
    // solve yet); the ranks agree on it between two steps, or a method without a clean stop
    // ends the job.
    if (!g_requested) g_requested = sig;
    return;
  }
  if (g_scope && !g_requested) {
    g_requested = sig;
    return;
  }
  removeRegistered();
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

}  // namespace

void installInterruptHandlers() {
  struct sigaction sa = {};
  sa.sa_handler = onSignal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

void interruptSignalsEndDistributedRun(int rank, int size) {
  const int n = std::snprintf(g_end_message, sizeof(g_end_message),
                              "penumbra: error: rank %d of %d: stopped by a signal (mpirun stops "
                              "every rank when one fails or the job is cancelled); nothing was "
                              "written\n",
                              rank, size);
  // Rank 0 speaks for all (a hundred ranks would print a hundred lines).
  g_end_message_length = n > 0 && rank == 0 ? std::min(size_t(n), sizeof(g_end_message) - 1) : 0;
  g_distributed = 1;
  struct sigaction sa = {};
  sa.sa_handler = onSignal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;
  sigaction(SIGUSR1, &sa, nullptr);
}

void requestInterrupt(int signal) {
  if (!g_requested) g_requested = signal;
}

bool interruptRequested() {
  return g_requested != 0;
}

void throwIfInterrupted() {
  if (g_requested && !g_scope) throw Interrupted();
}

void silenceDistributedEndMessage() {
  g_end_message_length = 0;
}

bool stoppedMidStep() {
  return g_requested == SIGINT || g_requested == SIGTERM;
}

void throwIfStoppedMidStep() {
  if (stoppedMidStep()) throw Interrupted();
}

void clearInterrupt() {
  g_requested = 0;
}

void keepInterruptRequests(bool keep) {
  g_keep_requests = keep;
}

InterruptScope::InterruptScope() {
  if (!g_keep_requests) g_requested = 0;
  g_scope = 1;
}

InterruptScope::~InterruptScope() {
  g_scope = 0;
}

bool InterruptScope::requested() {
  return g_requested != 0;
}

bool InterruptScope::active() {
  return g_scope != 0;
}

int InterruptScope::exitCode() {
  return 128 + (g_requested != 0 ? int(g_requested) : SIGINT);
}

CleanupOnSignal::CleanupOnSignal(const std::string& path, bool directory) {
  if (path.size() >= kPathBytes) return;
  for (int i = 0; i < kSlots; ++i) {
    bool expected = false;
    if (!g_slot_busy[i].compare_exchange_strong(expected, true)) continue;
    Slot& s = g_slots[i];
    std::memcpy(s.path, path.c_str(), path.size() + 1);
    s.order = g_order.fetch_add(1);
    std::atomic_signal_fence(std::memory_order_seq_cst);
    s.state = directory ? 2 : 1;
    slot_ = i;
    return;
  }
}

CleanupOnSignal::~CleanupOnSignal() {
  if (slot_ < 0) return;
  g_slots[slot_].state = 0;
  std::atomic_signal_fence(std::memory_order_seq_cst);
  g_slot_busy[slot_].store(false);
}

CleanupOnSignal::CleanupOnSignal(CleanupOnSignal&& other) noexcept : slot_(other.slot_) {
  other.slot_ = -1;
}

CleanupOnSignal& CleanupOnSignal::operator=(CleanupOnSignal&& other) noexcept {
  if (this != &other) {
    this->~CleanupOnSignal();
    slot_ = other.slot_;
    other.slot_ = -1;
  }
  return *this;
}

}  // namespace penumbra
