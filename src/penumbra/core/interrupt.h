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

#include <stdexcept>
#include <string>

namespace penumbra {

void installInterruptHandlers();
// In a run over several processes (cluster/communicator.h), SIGINT and SIGTERM end the process
// even inside an InterruptScope: mpirun sends them to every rank when one fails or the job is
// cancelled, and a rank cannot stop cleanly while the others are gone. SIGUSR1 (which mpirun
// passes on to every rank) is the request to stop cleanly instead, inside a scope or not
// (progressive radiosity writes its checkpoint; a method without a clean stop ends the job). The
// exit message names the rank.
void interruptSignalsEndDistributedRun(int rank, int size);
// Once the process has reported its error, the signal mpirun sends every rank next ends it without
// the exit message: one error, one line.
void silenceDistributedEndMessage();

// A request to stop, as the signal makes it: async-signal-safe, so a caller's own SIGINT handler
// may call it (the library's API does, penumbra.h: requestInterrupt). `signal` picks the exit code
// (InterruptScope::exitCode).
void requestInterrupt(int signal);
// Whether a stop was requested (by a signal inside a scope, or by requestInterrupt).
bool interruptRequested();
// Forgets a request.
void clearInterrupt();
// While true, a new InterruptScope keeps a request made before it (the API clears it once, when
// a call starts, and its handler may have asked to stop since).
void keepInterruptRequests(bool keep);

// Thrown where work without a clean stopping point of its own stops at a request (core/progress.h:
// ProgressObserver::stop_on_interrupt).
class Interrupted : public std::runtime_error {
 public:
  Interrupted() : std::runtime_error("interrupted") {}
};
// Throws Interrupted when a stop was requested and no InterruptScope is alive to stop cleanly.
// The CLI's signals set the flag only inside a scope, so under the CLI this never throws; a
// program calling the library (requestInterrupt) stops long work this way. Cheap enough to poll
// per pixel.
void throwIfInterrupted();

// For work inside an InterruptScope that has no clean stopping point of its own and may take
// minutes (the lights' shot of radiosity over 10,000 luminaires): throws Interrupted when SIGINT
// or SIGTERM (or a caller's requestInterrupt) asked to stop, instead of finishing the step first.
// The command then ends with the signal's exit code and no output. A distributed run's SIGUSR1
// is left to the ranks' agreement between two steps.
bool stoppedMidStep();  // whether throwIfStoppedMidStep would throw
void throwIfStoppedMidStep();

class InterruptScope {
 public:
  InterruptScope();   // clears the flag; signals now ask to stop
  ~InterruptScope();  // signals end the process again
  InterruptScope(const InterruptScope&) = delete;
  InterruptScope& operator=(const InterruptScope&) = delete;

  // Whether SIGINT or SIGTERM arrived since the scope began (any thread).
  static bool requested();
  // Whether a scope is alive (its work stops cleanly on a request, by itself).
  static bool active();
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
