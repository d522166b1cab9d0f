#include "penumbra/core/large_pages.h"

#include <cstdint>
#include <cstdlib>
#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace penumbra {

namespace {
// Small buffers: cache-line aligned, so SIMD loads of their start never split a line.
constexpr std::align_val_t kSmallAlign{64};

size_t roundedLarge(size_t bytes) {
  return (bytes + kLargePageBytes - 1) / kLargePageBytes * kLargePageBytes;
}
}  // namespace

void* allocateLarge(size_t bytes) {
  if (bytes < kLargePageBytes) return ::operator new(bytes, kSmallAlign);
  const size_t rounded = roundedLarge(bytes);
#if defined(__linux__)
  // A mapping of its own (not the heap, whose pages glibc may keep or trim as it likes), with
  // a 2 MiB-aligned start: map one large page more and unmap the ends.
  const size_t span = rounded + kLargePageBytes;
  void* raw = mmap(nullptr, span, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (raw == MAP_FAILED) throw std::bad_alloc();
  const uintptr_t start = uintptr_t(raw);
  const uintptr_t aligned = (start + kLargePageBytes - 1) & ~uintptr_t(kLargePageBytes - 1);
  if (aligned > start) munmap(raw, aligned - start);
  const uintptr_t end = start + span, used_end = aligned + rounded;
  if (end > used_end) munmap(reinterpret_cast<void*>(used_end), end - used_end);
  void* p = reinterpret_cast<void*>(aligned);
  madvise(p, rounded, MADV_HUGEPAGE);  // advice only: without THP the pages stay 4 KiB
  return p;
#else
  void* p = std::aligned_alloc(kLargePageBytes, rounded);
  if (!p) throw std::bad_alloc();
  return p;
#endif
}

void freeLarge(void* p, size_t bytes) noexcept {
  if (!p) return;
  if (bytes < kLargePageBytes) {
    ::operator delete(p, kSmallAlign);
    return;
  }
#if defined(__linux__)
  munmap(p, roundedLarge(bytes));
#else
  std::free(p);
#endif
}

}  // namespace penumbra
