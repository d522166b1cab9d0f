#include "penumbra/core/parallel.h"

#include <tbb/info.h>

namespace penumbra {

std::unique_ptr<tbb::global_control> limitThreads(int threads) {
  if (threads <= 0) return nullptr;
  return std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                               static_cast<size_t>(threads));
}

int threadCount() {
  return static_cast<int>(
      tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
}

}  // namespace penumbra
