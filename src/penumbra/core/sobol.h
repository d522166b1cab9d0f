// Low-discrepancy sample points for the path tracer: the first two dimensions of the Sobol
// sequence, Owen-scrambled by hashing, with the sample index shuffled per pattern (Burley,
// "Practical Hash-based Owen Scrambling", JCGT 9(4), 2020, sec. 3-4). The first 2^m points of a
// pattern form a (0, m, 2)-net (one point in every elementary interval of area 2^-m) for every
// m, and each point on its own is uniform on [0, 1)^2: estimates stay unbiased, while the
// strata of a pixel's samples cover the pixel, the light and the hemisphere evenly. Padding:
// every use (camera jitter, light sample, bounce direction, ...) is its own pattern, with its
// own seed, so patterns are independent of each other (Burley sec. 4).
//
// Everything is integer arithmetic, so the 4-lane SIMD form (owenSobol2DBitsReversedX4) gives
// the scalar form's points bit for bit, and an image does not depend on the machine.
#pragma once

#include "penumbra/core/rng.h"

#include <cstdint>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define PENUMBRA_SOBOL_X86 1
#else
#define PENUMBRA_SOBOL_X86 0
#endif

namespace penumbra {

// Bit reversal: a byte swap, then the bits within each byte.
inline uint32_t reverseBits32(uint32_t x) {
  x = __builtin_bswap32(x);
  x = ((x & 0x0f0f0f0fu) << 4) | ((x >> 4) & 0x0f0f0f0fu);
  x = ((x & 0x33333333u) << 2) | ((x >> 2) & 0x33333333u);
  x = ((x & 0x55555555u) << 1) | ((x >> 1) & 0x55555555u);
  return x;
}

// The Sobol sequence's dimensions 0 (van der Corput: the index's bits reversed) and 1
// (primitive polynomial x + 1: direction numbers v_0 = 2^31, v_k = v_{k-1} ^ (v_{k-1} >> 1)).
constexpr uint32_t sobolDirection1(int k) {
  uint32_t v = 1u << 31;
  for (int i = 0; i < k; ++i) v ^= v >> 1;
  return v;
}

// Dimension 1's point `index` with its bits reversed (the order the scrambling works in), without
// tables. Direction number v_k has bit 31 - j set iff the binomial C(k, j) is odd (its
// recurrence is Pascal's rule mod 2), which by Lucas' theorem is iff j is a submask of k. So bit
// j of the reversed point is the XOR of the index's bits k over the supermasks k of j: the
// superset transform over GF(2) on the five bits of a bit position, one step per bit.
inline uint32_t sobolDimension1Reversed(uint32_t index) {
  uint32_t r = index;
  r ^= (r >> 1) & 0x55555555u;
  r ^= (r >> 2) & 0x33333333u;
  r ^= (r >> 4) & 0x0f0f0f0fu;
  r ^= (r >> 8) & 0x00ff00ffu;
  r ^= r >> 16;
  return r;
}
inline uint32_t sobolDimension1(uint32_t index) {
  return reverseBits32(sobolDimension1Reversed(index));
}

// The Laine-Karras permutation (Burley listing 2): applied to reversed bits, it flips each bit
// of the value by a hash of the bits above it, which is Owen scrambling.
inline uint32_t laineKarrasPermutation(uint32_t x, uint32_t seed) {
  x += seed;
  x ^= x * 0x6c50b47cu;
  x ^= x * 0xb82f1e52u;
  x ^= x * 0xc7afe638u;
  x ^= x * 0x8d22f6e6u;
  return x;
}

// Owen scrambling of x's bits from the top (Burley sec. 3).
inline uint32_t nestedUniformScramble(uint32_t x, uint32_t seed) {
  return reverseBits32(laineKarrasPermutation(reverseBits32(x), seed));
}

// A 2-D pattern: the seeds of its index shuffle and of the scrambles of its two dimensions.
struct SobolPattern {
  uint32_t shuffle, scramble0, scramble1;
};

// Pattern `pattern` of pixel (or other stream) `key`.
inline SobolPattern sobolPattern(uint64_t key, uint32_t pattern) {
  const uint64_t h = mixBits(key ^ (uint64_t(pattern) * 0x9e3779b97f4a7c15ull));
  return {uint32_t(h >> 32), uint32_t(h), uint32_t(mixBits(h) >> 32)};
}

// Point `index` of pattern `p`, as 32-bit fractions. Burley's construction (sec. 4): the index
// is shuffled by a nested uniform scramble, i = NUS(index); the point is (NUS(rev(i)),
// NUS(sobol1(i))). The reversals cancel in pairs, as NUS(v) = rev(LK(rev(v))): dimension 0 is
// rev(LK(i)), dimension 1 rev(LK(rev(sobol1(i)))), with rev(sobol1(i)) computed directly.
struct SobolBits {
  uint32_t x, y;  // the point times 2^32
};
// With the index given bit-reversed (reverseBits32(index)), as a caller taking points of several
// patterns for one index reverses it once.
inline SobolBits owenSobol2DBitsReversed(uint32_t reversed_index, const SobolPattern& p) {
  const uint32_t i = reverseBits32(laineKarrasPermutation(reversed_index, p.shuffle));
  return {reverseBits32(laineKarrasPermutation(i, p.scramble0)),
          reverseBits32(laineKarrasPermutation(sobolDimension1Reversed(i), p.scramble1))};
}
inline SobolBits owenSobol2DBits(uint32_t index, const SobolPattern& p) {
  return owenSobol2DBitsReversed(reverseBits32(index), p);
}

#if PENUMBRA_SOBOL_X86
// The 4-lane form in SSE4.1 + SSSE3, and with GFNI for the bit reversals. Each is compiled for
// its instruction set whatever the build's -march (target attributes), so a portable build
// still runs them, chosen at run time (owenSobol2DBitsReversedX4); a build for a machine that
// has them inlines them.
namespace sobol_simd {

#define PENUMBRA_SOBOL_SSE __attribute__((target("sse4.1,ssse3")))
#define PENUMBRA_SOBOL_GFNI __attribute__((target("gfni,sse4.1,ssse3")))

PENUMBRA_SOBOL_SSE inline __m128i byteSwap(__m128i v) {
  return _mm_shuffle_epi8(v, _mm_setr_epi8(3, 2, 1, 0, 7, 6, 5, 4, 11, 10, 9, 8, 15, 14, 13, 12));
}

// Bit reversal: a byte swap, then the bits within each byte by a table of nibbles...
PENUMBRA_SOBOL_SSE inline __m128i reverseBitsShuffle(__m128i v) {
  v = byteSwap(v);
  const __m128i nibble =
      _mm_setr_epi8(0x0, 0x8, 0x4, 0xc, 0x2, 0xa, 0x6, 0xe, 0x1, 0x9, 0x5, 0xd, 0x3, 0xb, 0x7, 0xf);
  const __m128i low = _mm_set1_epi8(0x0f);
  const __m128i lo = _mm_shuffle_epi8(nibble, _mm_and_si128(v, low));
  const __m128i hi = _mm_shuffle_epi8(nibble, _mm_and_si128(_mm_srli_epi16(v, 4), low));
  return _mm_or_si128(_mm_slli_epi16(lo, 4), hi);
}

// ... or by the affine map over GF(2) with the anti-diagonal matrix.
PENUMBRA_SOBOL_GFNI inline __m128i reverseBitsGfni(__m128i v) {
  return _mm_gf2p8affine_epi64_epi8(byteSwap(v), _mm_set1_epi64x(0x8040201008040201ll), 0);
}

PENUMBRA_SOBOL_SSE inline __m128i laineKarras(__m128i x, __m128i seed) {
  x = _mm_add_epi32(x, seed);
  x = _mm_xor_si128(x, _mm_mullo_epi32(x, _mm_set1_epi32(int(0x6c50b47cu))));
  x = _mm_xor_si128(x, _mm_mullo_epi32(x, _mm_set1_epi32(int(0xb82f1e52u))));
  x = _mm_xor_si128(x, _mm_mullo_epi32(x, _mm_set1_epi32(int(0xc7afe638u))));
  x = _mm_xor_si128(x, _mm_mullo_epi32(x, _mm_set1_epi32(int(0x8d22f6e6u))));
  return x;
}

PENUMBRA_SOBOL_SSE inline __m128i dimension1Reversed(__m128i r) {
  r = _mm_xor_si128(r, _mm_and_si128(_mm_srli_epi32(r, 1), _mm_set1_epi32(0x55555555)));
  r = _mm_xor_si128(r, _mm_and_si128(_mm_srli_epi32(r, 2), _mm_set1_epi32(0x33333333)));
  r = _mm_xor_si128(r, _mm_and_si128(_mm_srli_epi32(r, 4), _mm_set1_epi32(0x0f0f0f0f)));
  r = _mm_xor_si128(r, _mm_and_si128(_mm_srli_epi32(r, 8), _mm_set1_epi32(0x00ff00ff)));
  return _mm_xor_si128(r, _mm_srli_epi32(r, 16));
}

struct Lanes {
  __m128i shuffle, s0, s1;
};
PENUMBRA_SOBOL_SSE inline Lanes lanes(const SobolPattern (&p)[4]) {
  return {
      _mm_setr_epi32(int(p[0].shuffle), int(p[1].shuffle), int(p[2].shuffle), int(p[3].shuffle)),
      _mm_setr_epi32(int(p[0].scramble0), int(p[1].scramble0), int(p[2].scramble0),
                     int(p[3].scramble0)),
      _mm_setr_epi32(int(p[0].scramble1), int(p[1].scramble1), int(p[2].scramble1),
                     int(p[3].scramble1))};
}

PENUMBRA_SOBOL_SSE inline void store(__m128i x, __m128i y, SobolBits (&out)[4]) {
  alignas(16) uint32_t xs[4], ys[4];
  _mm_store_si128(reinterpret_cast<__m128i*>(xs), x);
  _mm_store_si128(reinterpret_cast<__m128i*>(ys), y);
  for (int k = 0; k < 4; ++k) out[k] = {xs[k], ys[k]};
}

// The two kernels differ only in the bit reversal.
PENUMBRA_SOBOL_SSE inline void x4Sse41(uint32_t reversed_index, const SobolPattern (&p)[4],
                                       SobolBits (&out)[4]) {
  const Lanes l = lanes(p);
  const __m128i i = reverseBitsShuffle(laineKarras(_mm_set1_epi32(int(reversed_index)), l.shuffle));
  store(reverseBitsShuffle(laineKarras(i, l.s0)),
        reverseBitsShuffle(laineKarras(dimension1Reversed(i), l.s1)), out);
}

PENUMBRA_SOBOL_GFNI inline void x4Gfni(uint32_t reversed_index, const SobolPattern (&p)[4],
                                       SobolBits (&out)[4]) {
  const Lanes l = lanes(p);
  const __m128i i = reverseBitsGfni(laineKarras(_mm_set1_epi32(int(reversed_index)), l.shuffle));
  store(reverseBitsGfni(laineKarras(i, l.s0)),
        reverseBitsGfni(laineKarras(dimension1Reversed(i), l.s1)), out);
}

#undef PENUMBRA_SOBOL_SSE
#undef PENUMBRA_SOBOL_GFNI

}  // namespace sobol_simd
#endif

inline void owenSobol2DBitsReversedX4Scalar(uint32_t reversed_index, const SobolPattern (&p)[4],
                                            SobolBits (&out)[4]) {
  for (int k = 0; k < 4; ++k) out[k] = owenSobol2DBitsReversed(reversed_index, p[k]);
}

using SobolX4Kernel = void (*)(uint32_t, const SobolPattern (&)[4], SobolBits (&)[4]);
// The best 4-lane kernel this CPU runs (GFNI, SSE4.1 or scalar), chosen once at run time.
SobolX4Kernel sobolX4Kernel();

// Point `reversed_index` (as owenSobol2DBitsReversed) of four patterns at once: what a path
// vertex needs for all its decisions, in one pass of 4-lane integer SIMD where the machine has
// it. A build whose target has the instructions inlines the kernel; a portable one calls the
// kernel chosen at run time. Every kernel gives the scalar form's points bit for bit.
inline void owenSobol2DBitsReversedX4(uint32_t reversed_index, const SobolPattern (&p)[4],
                                      SobolBits (&out)[4]) {
#if PENUMBRA_SOBOL_X86 && defined(__GFNI__) && defined(__SSE4_1__) && defined(__SSSE3__)
  sobol_simd::x4Gfni(reversed_index, p, out);
#elif PENUMBRA_SOBOL_X86 && defined(__SSE4_1__) && defined(__SSSE3__)
  sobol_simd::x4Sse41(reversed_index, p, out);
#elif PENUMBRA_SOBOL_X86
  static const SobolX4Kernel kernel = sobolX4Kernel();
  kernel(reversed_index, p, out);
#else
  owenSobol2DBitsReversedX4Scalar(reversed_index, p, out);
#endif
}

// The same point as 24-bit floats in [0, 1)^2 (they never round to 1).
struct SobolPoint {
  float u, v;
};
inline float unitFloat(uint32_t bits) {
  return float(bits >> 8) * 0x1p-24f;
}
inline SobolPoint owenSobol2D(uint32_t index, const SobolPattern& p) {
  const SobolBits b = owenSobol2DBits(index, p);
  return {unitFloat(b.x), unitFloat(b.y)};
}

}  // namespace penumbra
