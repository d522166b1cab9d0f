#include "penumbra/core/interrupt.h"

#include <csignal>

namespace penumbra {

namespace {

volatile std::sig_atomic_t g_requested = 0;
struct sigaction g_previous;

extern "C" void onInterrupt(int) {
  if (g_requested) {
    // The second Ctrl-C: the default action (terminate), now.
    std::signal(SIGINT, SIG_DFL);
    std::raise(SIGINT);
    return;
  }
  g_requested = 1;
}

}  // namespace

InterruptScope::InterruptScope() {
  g_requested = 0;
  struct sigaction sa = {};
  sa.sa_handler = onInterrupt;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;
  sigaction(SIGINT, &sa, &g_previous);
}

InterruptScope::~InterruptScope() {
  sigaction(SIGINT, &g_previous, nullptr);
}

bool InterruptScope::requested() {
  return g_requested != 0;
}

}  // namespace penumbra
