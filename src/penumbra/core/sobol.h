// Low-discrepancy sample points for the path tracer: the first two dimensions of the Sobol
// sequence, Owen-scrambled by hashing, with the sample index shuffled per pattern (Burley,
// "Practical Hash-based Owen Scrambling", JCGT 9(4), 2020, sec. 3-4). The first 2^m points of a
// pattern form a (0, m, 2)-net (one point in every elementary interval of area 2^-m) for every
// m, and each point on its own is uniform on [0, 1)^2: estimates stay unbiased, while the
// strata of a pixel's samples cover the pixel, the light and the hemisphere evenly. Padding:
// every use (camera jitter, light sample, bounce direction, ...) is its own pattern, with its
// own seed, so patterns are independent of each other (Burley sec. 4).
#pragma once

#include "penumbra/core/rng.h"

#include <cstdint>

namespace penumbra {

// The Sobol sequence's dimensions 0 (van der Corput: the index's bits reversed) and 1
// (primitive polynomial x + 1: direction numbers v_0 = 2^31, v_k = v_{k-1} ^ (v_{k-1} >> 1)).
inline uint32_t reverseBits32(uint32_t x) {
  x = (x << 16) | (x >> 16);
  x = ((x & 0x00ff00ffu) << 8) | ((x & 0xff00ff00u) >> 8);
  x = ((x & 0x0f0f0f0fu) << 4) | ((x & 0xf0f0f0f0u) >> 4);
  x = ((x & 0x33333333u) << 2) | ((x & 0xccccccccu) >> 2);
  x = ((x & 0x55555555u) << 1) | ((x & 0xaaaaaaaau) >> 1);
  return x;
}

// Direction number k of dimension 1.
constexpr uint32_t sobolDirection1(int k) {
  uint32_t v = 1u << 31;
  for (int i = 0; i < k; ++i) v ^= v >> 1;
  return v;
}

// XOR of the direction numbers of the set bits of byte `b` at byte position `pos`.
struct SobolByteTables {
  uint32_t t[4][256];
  constexpr SobolByteTables() : t{} {
    for (int pos = 0; pos < 4; ++pos) {
      for (int b = 0; b < 256; ++b) {
        uint32_t x = 0;
        for (int bit = 0; bit < 8; ++bit) {
          if (b >> bit & 1) x ^= sobolDirection1(8 * pos + bit);
        }
        t[pos][b] = x;
      }
    }
  }
};
inline constexpr SobolByteTables kSobolDimension1Tables{};

// Four table lookups: the shuffled indices the path tracer uses have all 32 bits in play.
inline uint32_t sobolDimension1(uint32_t index) {
  const auto& t = kSobolDimension1Tables.t;
  return t[0][index & 255u] ^ t[1][(index >> 8) & 255u] ^ t[2][(index >> 16) & 255u] ^
         t[3][index >> 24];
}

// Owen scrambling of x's bits from the top (each bit flipped by a hash of the bits above it):
// the Laine-Karras permutation applied to the reversed bits (Burley listing 2 and sec. 3).
inline uint32_t nestedUniformScramble(uint32_t x, uint32_t seed) {
  x = reverseBits32(x);
  x += seed;
  x ^= x * 0x6c50b47cu;
  x ^= x * 0xb82f1e52u;
  x ^= x * 0xc7afe638u;
  x ^= x * 0x8d22f6e6u;
  return reverseBits32(x);
}

// Point `index` of the 2-D pattern `seed`, in [0, 1)^2 (24-bit floats that never round to 1).
struct SobolPoint {
  float u, v;
};
inline SobolPoint owenSobol2D(uint32_t index, uint32_t seed) {
  const uint32_t i = nestedUniformScramble(index, seed);
  const uint32_t s0 = uint32_t(mixBits(uint64_t(seed) << 1)),
                 s1 = uint32_t(mixBits(uint64_t(seed) << 1 | 1u));
  const uint32_t x = nestedUniformScramble(reverseBits32(i), s0);
  const uint32_t y = nestedUniformScramble(sobolDimension1(i), s1);
  return {float(x >> 8) * 0x1p-24f, float(y >> 8) * 0x1p-24f};
}

// The seed of pattern `pattern` of pixel (or other stream) `key`.
inline uint32_t sobolPatternSeed(uint64_t key, uint32_t pattern) {
  return uint32_t(mixBits(key ^ (uint64_t(pattern) * 0x9e3779b97f4a7c15ull)) >> 32);
}

}  // namespace penumbra
