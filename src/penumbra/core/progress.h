// A progress bar for long work: drawn on stderr when it is a terminal and not --quiet.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>

namespace penumbra {

// Where progress goes besides the bar: a program using the library (penumbra.h) is told through
// `report`, from whichever thread made the progress, at most five times a second per Progress
// (and once at its end). With `stop_on_interrupt`, add() and reach() throw Interrupted
// (core/interrupt.h) once a stop is requested, unless an InterruptScope is alive (that work stops
// cleanly by itself): the other long work then stops at its next progress step.
struct ProgressObserver {
  std::function<void(const std::string& label, double fraction)> report;
  bool stop_on_interrupt = false;
};
// Installs `observer` (or none) for the Progress objects made from now on, process-wide.
void setProgressObserver(const ProgressObserver* observer);

// The time left as the bar shows it, from the seconds spent and the fraction done, assuming the
// rest goes at the same pace: "12 s left", "3 min 05 s left", "2 h 10 min left"; empty while too
// little is done (under 1%, or under a second spent) to tell.
std::string formatTimeLeft(double elapsed_seconds, double fraction_done);

class Progress {
 public:
  // `total` units of work; `enabled` false draws nothing.
  Progress(std::string label, uint64_t total, bool enabled);
  ~Progress();

  // Thread-safe; redraws at most a few times per second.
  void add(uint64_t units);
  // Thread-safe: `done` units are finished (calls may arrive out of order; the largest wins).
  void reach(uint64_t done);
  void finish();
  // Thread-safe: a short text shown after the bar (e.g. "iteration 37, 0.012 unshot").
  void setNote(std::string note);

  // Whether stderr is a terminal.
  static bool stderrIsTerminal();

 private:
  void redraw(uint64_t done);
  void notify(uint64_t done, bool final);
  void draw(uint64_t done, bool final);

  std::string label_;
  std::string note_;  // guarded by mutex_
  uint64_t total_;
  bool enabled_;
  const ProgressObserver* observer_;
  std::atomic<double> last_notify_{-1.0};
  std::atomic<uint64_t> done_{0};
  std::mutex mutex_;
  double last_draw_ = -1.0;
  double start_ = 0.0;  // seconds (steady clock) when the work began
  bool finished_ = false;
};

}  // namespace penumbra
