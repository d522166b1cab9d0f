// The path tracer's low-discrepancy points (core/sobol.h).
#include "penumbra/core/sobol.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace penumbra {
namespace {

// The first 2^m points of a pattern put exactly one point in every elementary interval
// [i 2^-a, (i+1) 2^-a) x [j 2^-b, (j+1) 2^-b) with a + b = m: a (0, m, 2)-net, for every m up to
// 12 and several seeds (Owen scrambling keeps the net property of the Sobol points).
TEST(Sobol, EveryPrefixOfAPowerOfTwoIsANet) {
  for (const SobolPattern seed :
       {SobolPattern{0, 0, 0}, SobolPattern{1, 2, 3}, sobolPattern(0, 0), sobolPattern(12345, 7)}) {
    for (int m = 1; m <= 12; ++m) {
      const uint32_t n = 1u << m;
      std::vector<SobolPoint> pts;
      for (uint32_t i = 0; i < n; ++i) pts.push_back(owenSobol2D(i, seed));
      for (int a = 0; a <= m; ++a) {
        const int b = m - a;
        std::vector<int> count(n, 0);
        for (const SobolPoint& p : pts) {
          ASSERT_GE(p.u, 0.0f);
          ASSERT_LT(p.u, 1.0f);
          ASSERT_GE(p.v, 0.0f);
          ASSERT_LT(p.v, 1.0f);
          const uint32_t i = uint32_t(p.u * float(1u << a)), j = uint32_t(p.v * float(1u << b));
          ++count[(i << b) | j];
        }
        for (uint32_t c = 0; c < n; ++c) {
          ASSERT_EQ(count[c], 1) << "seed " << seed.shuffle << " m " << m << " a " << a << " cell "
                                 << c;
        }
      }
    }
  }
}

// The superset transform gives the direction numbers' XOR bit by bit.
TEST(Sobol, DimensionOneMatchesTheDirectionNumbers) {
  Rng rng(3, 3);
  for (int i = 0; i < 10000; ++i) {
    const uint32_t index = i < 64 ? uint32_t(i) : rng.nextU32();
    uint32_t expected = 0;
    for (int k = 0; k < 32; ++k) {
      if (index >> k & 1) expected ^= sobolDirection1(k);
    }
    ASSERT_EQ(sobolDimension1(index), expected) << index;
  }
  // The first points of dimension 1: 0, 1/2, 3/4, 1/4, 5/8.
  const float first[] = {0.0f, 0.5f, 0.75f, 0.25f, 0.625f};
  for (uint32_t i = 0; i < 5; ++i) EXPECT_EQ(float(sobolDimension1(i)) * 0x1p-32f, first[i]) << i;
}

// A reference bit reversal, one bit at a time.
uint32_t reverseBitByBit(uint32_t x) {
  uint32_t r = 0;
  for (int i = 0; i < 32; ++i) r |= ((x >> i) & 1u) << (31 - i);
  return r;
}

// The reversals the point computation saves cancel exactly: it equals Burley's construction
// written out, (NUS(rev(NUS(index))), NUS(sobol1(NUS(index)))); the 4-lane form gives the same
// bits; and the fast reversal is the reversal.
TEST(Sobol, PointsEqualTheConstructionWrittenOut) {
  Rng rng(5, 5);
  for (int t = 0; t < 20000; ++t) {
    const uint32_t index = t < 1024 ? uint32_t(t) : rng.nextU32();
    ASSERT_EQ(reverseBits32(index), reverseBitByBit(index)) << t;
    SobolPattern p[4];
    for (SobolPattern& q : p) q = sobolPattern(rng.nextU32(), uint32_t(t));
    SobolBits four[4];
    owenSobol2DBitsReversedX4(reverseBits32(index), p, four);
    for (int k = 0; k < 4; ++k) {
      const uint32_t i = nestedUniformScramble(index, p[k].shuffle);
      const uint32_t x = nestedUniformScramble(reverseBitByBit(i), p[k].scramble0);
      const uint32_t y = nestedUniformScramble(sobolDimension1(i), p[k].scramble1);
      const SobolBits one = owenSobol2DBits(index, p[k]);
      ASSERT_EQ(one.x, x) << t;
      ASSERT_EQ(one.y, y) << t;
      ASSERT_EQ(four[k].x, x) << t << " lane " << k;
      ASSERT_EQ(four[k].y, y) << t << " lane " << k;
      const SobolPoint q = owenSobol2D(index, p[k]);
      ASSERT_EQ(q.u, float(x >> 8) * 0x1p-24f) << t;
      ASSERT_EQ(q.v, float(y >> 8) * 0x1p-24f) << t;
    }
  }
}

// Every 4-lane kernel this CPU runs, the one chosen at run time for portable builds included,
// gives the scalar form's bits.
TEST(Sobol, EveryKernelGivesTheScalarBits) {
  std::vector<std::pair<const char*, SobolX4Kernel>> kernels = {
      {"chosen at run time", sobolX4Kernel()}, {"scalar", &owenSobol2DBitsReversedX4Scalar}};
#if PENUMBRA_SOBOL_X86
  if (__builtin_cpu_supports("sse4.1") && __builtin_cpu_supports("ssse3")) {
    kernels.emplace_back("sse4.1", &sobol_simd::x4Sse41);
    if (__builtin_cpu_supports("gfni")) kernels.emplace_back("gfni", &sobol_simd::x4Gfni);
  }
#endif
  Rng rng(9, 2);
  for (int t = 0; t < 20000; ++t) {
    const uint32_t reversed = rng.nextU32();
    SobolPattern p[4];
    for (SobolPattern& q : p) q = sobolPattern(rng.nextU32(), uint32_t(t));
    for (const auto& [name, kernel] : kernels) {
      SobolBits four[4];
      kernel(reversed, p, four);
      for (int k = 0; k < 4; ++k) {
        const SobolBits one = owenSobol2DBitsReversed(reversed, p[k]);
        ASSERT_EQ(four[k].x, one.x) << name << " " << t;
        ASSERT_EQ(four[k].y, one.y) << name << " " << t;
      }
    }
  }
}

// Each point alone is uniform over the seeds (what keeps the path tracer unbiased): the mean and
// variance of one index's point across 20,000 patterns are those of U[0, 1), and two patterns'
// points are uncorrelated.
TEST(Sobol, APointIsUniformOverPatternsAndPatternsAreIndependent) {
  for (uint32_t index : {0u, 1u, 5u, 1000u}) {
    double su = 0, sv = 0, suu = 0, suv = 0, cross = 0;
    const int n = 20000;
    for (int k = 0; k < n; ++k) {
      const SobolPoint p = owenSobol2D(index, sobolPattern(99, uint32_t(k)));
      const SobolPoint q = owenSobol2D(index, sobolPattern(99, uint32_t(k) + 100000u));
      su += p.u, sv += p.v, suu += double(p.u) * p.u, suv += double(p.u) * p.v;
      cross += double(p.u) * q.u;
    }
    EXPECT_NEAR(su / n, 0.5, 0.01) << index;
    EXPECT_NEAR(sv / n, 0.5, 0.01) << index;
    EXPECT_NEAR(suu / n, 1.0 / 3.0, 0.01) << index;
    EXPECT_NEAR(suv / n, 0.25, 0.01) << index;    // u and v of a point independent
    EXPECT_NEAR(cross / n, 0.25, 0.01) << index;  // patterns independent
  }
}

// The stratification pays: the mean of a smooth function over a pixel's first 256 points errs
// far less than over 256 independent random points (the path tracer's gain per sample).
TEST(Sobol, EstimatesConvergeFasterThanIndependentPoints) {
  const auto f = [](float u, float v) { return std::exp(-4.0 * (u * u + v * v)); };
  const double exact = std::pow(std::sqrt(std::acos(-1.0)) / 4.0 * std::erf(2.0), 2.0);
  double err_sobol = 0.0, err_random = 0.0;
  const int trials = 200, n = 256;
  for (int t = 0; t < trials; ++t) {
    Rng rng(7, uint64_t(t));
    double a = 0.0, b = 0.0;
    for (int i = 0; i < n; ++i) {
      const SobolPoint p = owenSobol2D(uint32_t(i), sobolPattern(uint64_t(t), 3));
      a += f(p.u, p.v);
      const float u = rng.uniform();
      b += f(u, rng.uniform());
    }
    err_sobol += std::pow(a / n - exact, 2.0);
    err_random += std::pow(b / n - exact, 2.0);
  }
  // Random points: variance / 256; scrambled nets: O(n^-3 log n) for smooth functions.
  EXPECT_LT(err_sobol * 20.0, err_random)
      << std::sqrt(err_sobol / trials) << " vs " << std::sqrt(err_random / trials);
}

}  // namespace
}  // namespace penumbra
