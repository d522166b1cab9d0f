// SIGINT (Ctrl-C) and SIGTERM: a request to stop long work cleanly, and no debris when the
// process ends by them.
//
//  - installInterruptHandlers() (the command-line tool calls it once at start) installs one
//    handler for both signals.
//  - While an InterruptScope is alive, the first signal only sets a flag that the work polls
//    between steps (progressive radiosity then writes its current solution and a checkpoint, and
//    the command exits with 128 + the signal's number, 130 or 143).
//  - Any other signal (outside a scope, or a second one inside) ends the process as the signal
//    does by default, after removing the paths registered with CleanupOnSignal: the temporaries
//    of outputs not yet placed and the directories this run created (core/file_util.h). Only
//    async-signal-safe calls (unlink, rmdir) run in the handler.
#pragma once

#include <string>

namespace penumbra {

void installInterruptHandlers();

class InterruptScope {
 public:
  InterruptScope();   // clears the flag; signals now ask to stop
  ~InterruptScope();  // signals end the process again
  InterruptScope(const InterruptScope&) = delete;
  InterruptScope& operator=(const InterruptScope&) = delete;

  // Whether SIGINT or SIGTERM arrived since the scope began (any thread).
  static bool requested();
  // The exit code for a run stopped by that signal: 130 (SIGINT) or 143 (SIGTERM).
  static int exitCode();
};

// A path removed if SIGINT or SIGTERM ends the process while the object lives (files before
// directories, the latest directory first); releasing it (destruction) keeps it. Paths longer
// than the registry holds, or more than it has room for, are not registered (the process still
// removes them on a normal exit).
class CleanupOnSignal {
 public:
  CleanupOnSignal() = default;
  CleanupOnSignal(const std::string& path, bool directory);
  ~CleanupOnSignal();
  CleanupOnSignal(CleanupOnSignal&& other) noexcept;
  CleanupOnSignal& operator=(CleanupOnSignal&& other) noexcept;
  CleanupOnSignal(const CleanupOnSignal&) = delete;
  CleanupOnSignal& operator=(const CleanupOnSignal&) = delete;

 private:
  int slot_ = -1;
};

// Exit code of a run that stopped on SIGINT after writing what it had (128 + SIGINT, as shells
// report a process ended by the signal).
inline constexpr int kInterruptedExitCode = 130;

}  // namespace penumbra
