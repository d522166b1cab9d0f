// FNV-1a, 64 bits: fingerprints of inputs (checkpoints, caches), not for security.
#pragma once

#include <cstddef>
#include <cstdint>

namespace penumbra {

struct Fnv1a {
  uint64_t h = 0xcbf29ce484222325ull;
  void add(const void* data, size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < n; ++i) {
      h ^= p[i];
      h *= 0x100000001b3ull;
    }
  }
  template <typename T>
  void addValue(const T& v) {
    add(&v, sizeof(v));
  }
};

}  // namespace penumbra
