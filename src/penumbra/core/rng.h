// Random numbers: PCG32 (O'Neill 2014, pcg-cpp) with explicit stream selection, so that every
// pixel, path or element gets its own deterministic sequence regardless of thread scheduling.
#pragma once

#include <pcg_random.hpp>

#include <cstdint>

namespace penumbra {

class Rng {
 public:
  Rng() = default;
  // `seed` picks the sequence start, `stream` one of 2^63 independent streams.
  Rng(uint64_t seed, uint64_t stream) : gen_(seed, stream) {}

  uint32_t nextU32() { return gen_(); }
  // Uniform in [0, 1): 24 random mantissa bits, never rounds up to 1.
  float uniform() { return float(gen_() >> 8) * 0x1p-24f; }
  // Uniform integer in [0, n).
  uint32_t uniformInt(uint32_t n) { return gen_(n); }
  void advance(uint64_t delta) { gen_.advance(delta); }

 private:
  pcg32 gen_;
};

// Mixes several integers into one well-distributed 64-bit key (splitmix64 finaliser).
inline uint64_t mixBits(uint64_t v) {
  v ^= v >> 31;
  v *= 0x7fb5d329728ea185ULL;
  v ^= v >> 27;
  v *= 0x81dadef4bc2dd44dULL;
  v ^= v >> 33;
  return v;
}

// The same for 32 bits ("lowbias32", C. Wellons' hash-prospector), where shaders must compute
// the same numbers without 64-bit integers.
inline uint32_t mixBits32(uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352du;
  x ^= x >> 15;
  x *= 0x846ca68bu;
  x ^= x >> 16;
  return x;
}

}  // namespace penumbra
