#include "penumbra/core/progress.h"

#include "penumbra/core/interrupt.h"

#include <unistd.h>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

namespace penumbra {

namespace {
double nowSeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::atomic<const ProgressObserver*> g_observer{nullptr};
}  // namespace

void setProgressObserver(const ProgressObserver* observer) {
  g_observer = observer;
}

std::string formatTimeLeft(double elapsed, double fraction) {
  if (!(fraction >= 0.01 && fraction < 1.0) || !(elapsed >= 1.0)) return {};
  const double left = elapsed * (1.0 - fraction) / fraction;
  if (!(left < 1e7)) return {};
  const long s = std::lround(left);
  char text[48];
  if (s < 60) {
    std::snprintf(text, sizeof text, "%ld s left", s);
  } else if (s < 3600) {
    std::snprintf(text, sizeof text, "%ld min %02ld s left", s / 60, s % 60);
  } else {
    std::snprintf(text, sizeof text, "%ld h %02ld min left", s / 3600, (s % 3600) / 60);
  }
  return text;
}

Progress::Progress(std::string label, uint64_t total, bool enabled)
    : label_(std::move(label)),
      total_(total),
      enabled_(enabled && total > 0),
      observer_(g_observer.load()),
      start_(nowSeconds()) {
  if (enabled_) draw(0, false);
  notify(0, false);
}

Progress::~Progress() {
  finish();
}

bool Progress::stderrIsTerminal() {
  return ::isatty(STDERR_FILENO) == 1;
}

void Progress::add(uint64_t units) {
  redraw(done_.fetch_add(units) + units);
}

void Progress::reach(uint64_t done) {
  uint64_t seen = done_.load();
  while (seen < done && !done_.compare_exchange_weak(seen, done)) {
  }
  redraw(std::max(seen, done));
}

void Progress::notify(uint64_t done, bool final) {
  if (!observer_) return;
  if (!final && observer_->stop_on_interrupt) throwIfInterrupted();
  if (!observer_->report) return;
  const double now = nowSeconds();
  double last = last_notify_.load();
  // One thread reports per interval; the final report always goes.
  if (!final && (now - last < 0.2 || !last_notify_.compare_exchange_strong(last, now))) return;
  if (final) last_notify_ = now;
  const double frac = total_ ? double(done < total_ ? done : total_) / double(total_) : 1.0;
  observer_->report(label_, frac);
}

void Progress::redraw(uint64_t done) {
  notify(done, false);
  if (!enabled_) return;
  std::unique_lock lock(mutex_, std::try_to_lock);
  if (!lock.owns_lock() || finished_) return;
  const double now = nowSeconds();
  if (now - last_draw_ < 0.2) return;
  last_draw_ = now;
  draw(done, false);
}

void Progress::finish() {
  {
    std::lock_guard lock(mutex_);
    if (finished_) return;
    finished_ = true;
    if (enabled_) draw(done_.load(), true);
  }
  notify(done_.load(), true);
}

void Progress::setNote(std::string note) {
  if (!enabled_) return;
  std::lock_guard lock(mutex_);
  note_ = std::move(note);
}

void Progress::draw(uint64_t done, bool final) {
  constexpr int kWidth = 40;
  const double frac = total_ ? double(done < total_ ? done : total_) / double(total_) : 1.0;
  const int filled = int(frac * kWidth);
  std::string bar(size_t(filled), '#');
  bar.append(size_t(kWidth - filled), '.');
  // The note is padded so that a shorter one overwrites a longer one drawn before.
  std::string note = note_.empty() ? std::string() : "  " + note_;
  if (!final) {
    const std::string left = formatTimeLeft(nowSeconds() - start_, frac);
    if (!left.empty()) note += (note.empty() ? "  " : ", ") + left;
  }
  if (note.size() < 56) note.append(56 - note.size(), ' ');
  std::fprintf(stderr, "\r%s [%s] %5.1f%%%s%s", label_.c_str(), bar.c_str(), frac * 100.0,
               note.c_str(), final ? "\n" : "");
  std::fflush(stderr);
}

}  // namespace penumbra
