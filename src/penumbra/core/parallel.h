// Threading through oneTBB. `--threads N` installs a global limit for the process.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <cstddef>
#include <memory>

namespace penumbra {

// Limits TBB to `threads` workers for as long as the returned object lives (0 = all cores).
std::unique_ptr<tbb::global_control> limitThreads(int threads);

// Number of threads TBB will use.
int threadCount();

// Calls body(begin, end) over [0, n) in chunks of about `grain` items, in parallel.
template <typename Body>
void parallelRange(size_t n, size_t grain, Body&& body) {
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, grain),
                    [&](const tbb::blocked_range<size_t>& r) { body(r.begin(), r.end()); });
}

}  // namespace penumbra
