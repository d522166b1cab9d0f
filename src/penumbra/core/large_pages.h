// Large buffers (ray and hit batches, leaf blocks, images) on transparent huge pages. On a
// virtual machine a first touch of a 4 KiB page costs about 10 us (measured here: zeroing a new
// 16 MiB buffer took 41 ms on 4 KiB pages, 1.5 ms on 2 MiB pages), which a tracer of 1M rays
// otherwise pays on every new hit batch. Allocations of 2 MiB or more are 2 MiB-aligned and
// advised MADV_HUGEPAGE (Linux; elsewhere plain allocations); smaller ones go to operator new.
#pragma once

#include <cstddef>
#include <new>
#include <vector>

namespace penumbra {

inline constexpr size_t kLargePageBytes = size_t(2) << 20;

// Throws std::bad_alloc when the memory is not there, as operator new does.
void* allocateLarge(size_t bytes);
void freeLarge(void* p, size_t bytes) noexcept;

template <typename T>
struct LargePageAllocator {
  using value_type = T;
  LargePageAllocator() = default;
  template <typename U>
  LargePageAllocator(const LargePageAllocator<U>&) noexcept {}
  T* allocate(size_t n) {
    static_assert(alignof(T) <= kLargePageBytes);
    if (n > size_t(-1) / sizeof(T)) throw std::bad_array_new_length();
    return static_cast<T*>(allocateLarge(n * sizeof(T)));
  }
  void deallocate(T* p, size_t n) noexcept { freeLarge(p, n * sizeof(T)); }
  template <typename U>
  bool operator==(const LargePageAllocator<U>&) const noexcept {
    return true;
  }
};

template <typename T>
using LargeVector = std::vector<T, LargePageAllocator<T>>;

}  // namespace penumbra
