// Ctrl-C (SIGINT) as a request to stop long work cleanly: while an InterruptScope is alive, the
// first SIGINT only sets a flag that the work polls between steps (progressive radiosity then
// writes its current solution and a checkpoint); a second one ends the process at once, as
// SIGINT normally does.
#pragma once

namespace penumbra {

class InterruptScope {
 public:
  InterruptScope();   // installs the handler and clears the flag
  ~InterruptScope();  // restores the previous handler
  InterruptScope(const InterruptScope&) = delete;
  InterruptScope& operator=(const InterruptScope&) = delete;

  // Whether SIGINT arrived since the scope began (async-signal-safe flag; any thread).
  static bool requested();
};

// Exit code of a run that stopped on SIGINT after writing what it had (128 + SIGINT, as shells
// report a process ended by the signal).
inline constexpr int kInterruptedExitCode = 130;

}  // namespace penumbra
