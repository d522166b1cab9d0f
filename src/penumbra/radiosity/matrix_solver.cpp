#include "penumbra/radiosity/matrix_solver.h"

#include "penumbra/core/check.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"

#include <glm/geometric.hpp>

#include <cpuid.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define PENUMBRA_MATRIX_SIMD 1
#define PENUMBRA_MATRIX_TARGET __attribute__((target("avx2,fma,f16c")))
#else
#define PENUMBRA_MATRIX_SIMD 0
#define PENUMBRA_MATRIX_TARGET
#endif

namespace penumbra {

const char* matrixSolverName(MatrixSolver solver) {
  return solver == MatrixSolver::kJacobi ? "jacobi" : "gauss-seidel";
}
const char* matrixPrecisionName(MatrixPrecision precision) {
  return precision == MatrixPrecision::kFp32 ? "fp32" : "fp16";
}

uint16_t floatToHalf(float value) {
  uint32_t x;
  std::memcpy(&x, &value, 4);
  const uint32_t sign = (x >> 16) & 0x8000u;
  const uint32_t abs = x & 0x7fffffffu;
  if (abs >= 0x7f800000u) {  // inf or NaN
    return uint16_t(sign | 0x7c00u | (abs > 0x7f800000u ? 0x200u | ((abs >> 13) & 0x3ffu) : 0u));
  }
  if (abs >= 0x477ff000u) return uint16_t(sign | 0x7c00u);  // rounds to >= 65520: infinity
  if (abs < 0x38800000u) {
    // Subnormal half (or zero): value = mantissa * 2^-24, rounded to nearest even.
    if (abs < 0x33000000u) return uint16_t(sign);  // below half the smallest subnormal
    const uint32_t e = abs >> 23;
    const uint32_t mant = (abs & 0x7fffffu) | 0x800000u;
    const uint32_t shift = 126u - e;  // 14 + (112 - e) + 1 - 1
    uint32_t h = mant >> shift;
    const uint32_t rem = mant & ((1u << shift) - 1u), half = 1u << (shift - 1u);
    if (rem > half || (rem == half && (h & 1u))) ++h;
    return uint16_t(sign | h);
  }
  // Normal: rebias the exponent, round the mantissa to 10 bits (nearest even).
  uint32_t h = ((abs - 0x38000000u) >> 13);
  const uint32_t rem = abs & 0x1fffu;
  if (rem > 0x1000u || (rem == 0x1000u && (h & 1u))) ++h;
  return uint16_t(sign | h);
}

float halfToFloat(uint16_t half) {
  const uint32_t sign = uint32_t(half & 0x8000u) << 16;
  const uint32_t e = (half >> 10) & 0x1fu, mant = half & 0x3ffu;
  uint32_t x;
  if (e == 0) {
    if (mant == 0) {
      x = sign;
    } else {  // subnormal: normalise
      const float v = float(mant) * 0x1p-24f;
      std::memcpy(&x, &v, 4);
      x |= sign;
    }
  } else if (e == 31) {
    x = sign | 0x7f800000u | (mant << 13);
  } else {
    x = sign | ((e + 112u) << 23) | (mant << 13);
  }
  float out;
  std::memcpy(&out, &x, 4);
  return out;
}

RadiositySystem::RadiositySystem(FormFactorMatrix form_factors, MatrixPrecision precision)
    : reflectance(form_factors.n, glm::vec3(0.0f)),
      emission(form_factors.n, glm::vec3(0.0f)),
      n_(form_factors.n),
      row_begin_(form_factors.row_begin),
      rows_(form_factors.rowsHeld()),
      precision_(precision) {
  PENUMBRA_CHECK(form_factors.f.size() == size_t(rows_) * n_ && row_begin_ + rows_ <= n_);
  if (precision == MatrixPrecision::kFp32) {
    f32_ = std::move(form_factors.f);
  } else {
    f16_.resize(form_factors.f.size());
    parallelRange(f16_.size(), 1 << 16, [&](size_t b, size_t e) {
      for (size_t i = b; i < e; ++i) f16_[i] = floatToHalf(form_factors.f[i]);
    });
  }
}

float RadiositySystem::formFactor(uint32_t i, uint32_t j) const {
  const size_t k = size_t(i - row_begin_) * n_ + j;
  return precision_ == MatrixPrecision::kFp32 ? f32_[k] : halfToFloat(f16_[k]);
}

uint64_t RadiositySystem::matrixBytes() const {
  return precision_ == MatrixPrecision::kFp32 ? f32_.size() * 4 : f16_.size() * 2;
}

namespace {

// The right-hand vectors as structures of arrays, padded with zeros to a multiple of 8.
struct Channels {
  std::vector<float> c[3];
  void load(std::span<const glm::vec3> v, size_t padded) {
    for (int k = 0; k < 3; ++k) {
      c[k].assign(padded, 0.0f);
      for (size_t i = 0; i < v.size(); ++i) c[k][i] = v[i][k];
    }
  }
};

size_t padded(size_t n) {
  return (n + 7) / 8 * 8;
}

bool haveSimd() {
#if PENUMBRA_MATRIX_SIMD
  // F16C from CPUID leaf 1 (ECX bit 29): clang's __builtin_cpu_supports does not know it.
  static const bool has = [] {
    unsigned a = 0, b = 0, c = 0, d = 0;
    const bool f16c = __get_cpuid(1, &a, &b, &c, &d) && (c & bit_F16C) != 0;
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") && f16c;
  }();
  return has;
#else
  return false;
#endif
}

// Row dot products: out[k] += sum_j F_ij x_k[j] for K right-hand vectors (K = 3: one matrix
// read serves three channels; K = 6: the Gauss-Seidel sweep's old values and updates).
template <int K>
void rowDotScalar(const float* f, const uint16_t* h, const float* const* x, size_t n, double* out) {
  float acc[K] = {};
  for (size_t j = 0; j < n; ++j) {
    const float fij = f ? f[j] : halfToFloat(h[j]);
    for (int k = 0; k < K; ++k) acc[k] += fij * x[k][j];
  }
  for (int k = 0; k < K; ++k) out[k] = double(acc[k]);
}

#if PENUMBRA_MATRIX_SIMD
template <int K>
PENUMBRA_MATRIX_TARGET void rowDotAvx2(const float* f, const uint16_t* h, const float* const* x,
                                       size_t n, double* out) {
  // Two independent accumulators per vector to hide the FMA latency.
  __m256 acc0[K], acc1[K];
  for (int k = 0; k < K; ++k) acc0[k] = acc1[k] = _mm256_setzero_ps();
  size_t j = 0;
  const size_t n16 = n / 16 * 16;
  for (; j < n16; j += 16) {
    __m256 f0, f1;
    if (f) {
      f0 = _mm256_loadu_ps(f + j);
      f1 = _mm256_loadu_ps(f + j + 8);
    } else {
      f0 = _mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(h + j)));
      f1 = _mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(h + j + 8)));
    }
    for (int k = 0; k < K; ++k) {
      acc0[k] = _mm256_fmadd_ps(f0, _mm256_loadu_ps(x[k] + j), acc0[k]);
      acc1[k] = _mm256_fmadd_ps(f1, _mm256_loadu_ps(x[k] + j + 8), acc1[k]);
    }
  }
  for (; j < n; j += 8) {  // n is padded to a multiple of 8 in x, not in f: mask the tail
    alignas(32) float tail[8] = {};
    const size_t m = std::min<size_t>(8, n - j);
    for (size_t q = 0; q < m; ++q) tail[q] = f ? f[j + q] : halfToFloat(h[j + q]);
    const __m256 f0 = _mm256_load_ps(tail);
    for (int k = 0; k < K; ++k) acc0[k] = _mm256_fmadd_ps(f0, _mm256_loadu_ps(x[k] + j), acc0[k]);
  }
  for (int k = 0; k < K; ++k) {
    alignas(32) float lanes[8];
    _mm256_store_ps(lanes, _mm256_add_ps(acc0[k], acc1[k]));
    double s = 0.0;
    for (float v : lanes) s += double(v);
    out[k] = s;
  }
}
#endif

template <int K>
void rowDot(const RadiositySystem& sys, uint32_t i, const float* const* x, double* out) {
  const size_t n = sys.size(), off = size_t(i - sys.rowBegin()) * n;
  const float* f = sys.precision() == MatrixPrecision::kFp32 ? sys.f32().data() + off : nullptr;
  const uint16_t* h = f ? nullptr : sys.f16().data() + off;
#if PENUMBRA_MATRIX_SIMD
  if (haveSimd()) return rowDotAvx2<K>(f, h, x, n, out);
#endif
  rowDotScalar<K>(f, h, x, n, out);
}

// Four rows at once, three right-hand vectors (Jacobi): each load of B serves four rows, so the
// kernel reads little besides the matrix itself (the rows of F stream from memory; B stays in
// cache). out[r * 3 + k] = sum_j F_{i+r, j} x_k[j].
void rowsDot4x3Scalar(const RadiositySystem& sys, uint32_t i, const float* const* x, double* out) {
  for (int r = 0; r < 4; ++r) rowDot<3>(sys, i + uint32_t(r), x, out + 3 * r);
}

#if PENUMBRA_MATRIX_SIMD
PENUMBRA_MATRIX_TARGET void rowsDot4x3Avx2(const float* f, const uint16_t* h, size_t stride,
                                           const float* const* x, size_t n, double* out) {
  __m256 acc[4][3];
  for (auto& row : acc) {
    for (__m256& a : row) a = _mm256_setzero_ps();
  }
  const size_t n8 = n / 8 * 8;
  for (size_t j = 0; j < n8; j += 8) {
    const __m256 b0 = _mm256_loadu_ps(x[0] + j), b1 = _mm256_loadu_ps(x[1] + j);
    const __m256 b2 = _mm256_loadu_ps(x[2] + j);
    for (int r = 0; r < 4; ++r) {
      const __m256 fr = f ? _mm256_loadu_ps(f + size_t(r) * stride + j)
                          : _mm256_cvtph_ps(_mm_loadu_si128(
                                reinterpret_cast<const __m128i*>(h + size_t(r) * stride + j)));
      acc[r][0] = _mm256_fmadd_ps(fr, b0, acc[r][0]);
      acc[r][1] = _mm256_fmadd_ps(fr, b1, acc[r][1]);
      acc[r][2] = _mm256_fmadd_ps(fr, b2, acc[r][2]);
    }
  }
  for (int r = 0; r < 4; ++r) {
    for (int k = 0; k < 3; ++k) {
      alignas(32) float lanes[8];
      _mm256_store_ps(lanes, acc[r][k]);
      double sum = 0.0;
      for (float v : lanes) sum += double(v);
      for (size_t j = n8; j < n; ++j) {
        const float fij = f ? f[size_t(r) * stride + j] : halfToFloat(h[size_t(r) * stride + j]);
        sum += double(fij * x[k][j]);
      }
      out[r * 3 + k] = sum;
    }
  }
}
#endif

void rowsDot4x3(const RadiositySystem& sys, uint32_t i, const float* const* x, double* out) {
#if PENUMBRA_MATRIX_SIMD
  if (haveSimd()) {
    const size_t n = sys.size(), off = size_t(i - sys.rowBegin()) * n;
    const float* f = sys.precision() == MatrixPrecision::kFp32 ? sys.f32().data() + off : nullptr;
    const uint16_t* h = f ? nullptr : sys.f16().data() + off;
    return rowsDot4x3Avx2(f, h, n, x, n, out);
  }
#endif
  rowsDot4x3Scalar(sys, i, x, out);
}

// The rows this system holds of (F B): out[i] for i in [rowBegin, rowEnd), zero elsewhere.
std::vector<glm::dvec3> gatherHeldRows(const RadiositySystem& sys, std::span<const glm::vec3> b) {
  const uint32_t n = sys.size();
  PENUMBRA_CHECK(b.size() == n);
  Channels x;
  x.load(b, padded(n));
  const float* xs[3] = {x.c[0].data(), x.c[1].data(), x.c[2].data()};
  std::vector<glm::dvec3> out(n, glm::dvec3(0.0));
  parallelRange(sys.rowEnd() - sys.rowBegin(), 16, [&](size_t begin, size_t end) {
    for (size_t r = begin; r < end; ++r) {
      const size_t i = sys.rowBegin() + r;
      double g[3];
      rowDot<3>(sys, uint32_t(i), xs, g);
      out[i] = glm::dvec3(g[0], g[1], g[2]);
    }
  });
  return out;
}

// The rows held, completed from the other ranks: each rank's rows of `v` (one T per row, sizeof
// T bytes), gathered in rank order, which is row order.
template <typename T>
void completeRows(const RadiositySystem& sys, Communicator* comm, std::span<T> v) {
  if (!comm || !comm->distributed()) return;
  const std::vector<T> all = allgatherValues<T>(
      *comm, std::span<const T>(v.data() + sys.rowBegin(), sys.rowEnd() - sys.rowBegin()));
  PENUMBRA_CHECK(all.size() == v.size());
  std::copy(all.begin(), all.end(), v.begin());
}

// Jacobi (eq. 4) on the rows held: next[i] and the row's squared residual, summed over its
// channels, for i in [rowBegin, rowEnd).
void jacobiRows(const RadiositySystem& sys, std::span<const glm::vec3> b, std::span<glm::vec3> next,
                std::span<double> row_residual) {
  const uint32_t n = sys.size();
  PENUMBRA_CHECK(b.size() == n && next.size() == n && row_residual.size() == n &&
                 sys.reflectance.size() == n && sys.emission.size() == n);
  Channels x;
  x.load(b, padded(n));
  const float* xs[3] = {x.c[0].data(), x.c[1].data(), x.c[2].data()};
  const uint32_t row_begin = sys.rowBegin(), rows = sys.rowEnd() - sys.rowBegin();
  // Blocks of four rows (the last block may be shorter).
  parallelRange((rows + 3) / 4, 4, [&](size_t block_begin, size_t block_end) {
    for (size_t blk = block_begin; blk < block_end; ++blk) {
      double g4[12];
      const size_t first = row_begin + blk * 4;
      const size_t count = std::min<size_t>(4, row_begin + rows - first);
      if (count == 4) {
        rowsDot4x3(sys, uint32_t(first), xs, g4);
      } else {
        for (size_t r = 0; r < count; ++r) rowDot<3>(sys, uint32_t(first + r), xs, g4 + 3 * r);
      }
      for (size_t i = first; i < first + count; ++i) {
        const double* g = g4 + 3 * (i - first);  // (F B)_i
        const double fii = double(sys.formFactor(uint32_t(i), uint32_t(i)));
        double r2 = 0.0;
        for (int c = 0; c < 3; ++c) {
          const double rho = sys.reflectance[i][c];
          // (M B - E)_i = B_i - rho_i (F B)_i - E_i; diag(M)_ii = 1 - rho_i F_ii (eq. 4).
          const double r = double(b[i][c]) - rho * g[c] - double(sys.emission[i][c]);
          next[i][c] = float(double(b[i][c]) - r / (1.0 - rho * fii));
          r2 += r * r;
        }
        row_residual[i] = r2;
      }
    }
  });
}

double meanOf(std::span<const double> row_residual) {
  double sum = 0.0;
  for (double r : row_residual) sum += r;
  return sum / (3.0 * double(std::max<size_t>(1, row_residual.size())));
}

// Gauss-Seidel on the rows held, in place, with the other rows' B as they were when the sweep
// began (one process: the sweep of every row). Writes each held row's squared residual before
// its update.
void gaussSeidelRows(const RadiositySystem& sys, std::span<glm::vec3> b,
                     std::span<double> row_residual) {
  const uint32_t n = sys.size();
  PENUMBRA_CHECK(b.size() == n && sys.reflectance.size() == n && sys.emission.size() == n);
  // x[0..2]: B at the start of the sweep; x[3..5]: the updates made so far (zero for rows not
  // yet visited). Row i's sum with the current B is their sum; with the old B alone it gives
  // the residual of the iterate the sweep started from.
  Channels old_b, delta;
  old_b.load(b, padded(n));
  for (int k = 0; k < 3; ++k) delta.c[k].assign(padded(n), 0.0f);
  const float* xs[6] = {old_b.c[0].data(), old_b.c[1].data(), old_b.c[2].data(),
                        delta.c[0].data(), delta.c[1].data(), delta.c[2].data()};
  for (uint32_t i = sys.rowBegin(); i < sys.rowEnd(); ++i) {
    double g[6];
    rowDot<6>(sys, i, xs, g);
    const double fii = double(sys.formFactor(i, i));
    double r2 = 0.0;
    for (int c = 0; c < 3; ++c) {
      const double rho = sys.reflectance[i][c], e = sys.emission[i][c];
      const double old = old_b.c[c][i];
      const double r = old - rho * g[c] - e;
      r2 += r * r;
      // B_i = (E_i + rho_i sum_{j != i} F_ij B_j) / (1 - rho_i F_ii), with the current B.
      const double updated = (e + rho * (g[c] + g[3 + c] - fii * old)) / (1.0 - rho * fii);
      b[i][c] = float(updated);
      delta.c[c][i] = float(double(b[i][c]) - old);
    }
    row_residual[i] = r2;
  }
}

}  // namespace

std::vector<glm::dvec3> gatherIrradiance(const RadiositySystem& sys, std::span<const glm::vec3> b,
                                         Communicator* comm) {
  std::vector<glm::dvec3> out = gatherHeldRows(sys, b);
  completeRows<glm::dvec3>(sys, comm, out);
  return out;
}

double meanSquaredResidual(const RadiositySystem& sys, std::span<const glm::vec3> b,
                           Communicator* comm) {
  std::vector<glm::vec3> next(b.size());
  std::vector<double> row_residual(b.size(), 0.0);
  jacobiRows(sys, b, next, row_residual);
  completeRows<double>(sys, comm, row_residual);
  return meanOf(row_residual);
}

double jacobiStep(const RadiositySystem& sys, std::span<const glm::vec3> b,
                  std::span<glm::vec3> next) {
  std::vector<double> row_residual(b.size(), 0.0);
  jacobiRows(sys, b, next, row_residual);
  return meanOf(row_residual);
}

double gaussSeidelSweep(const RadiositySystem& sys, std::span<glm::vec3> b) {
  std::vector<double> row_residual(b.size(), 0.0);
  gaussSeidelRows(sys, b, row_residual);
  return meanOf(row_residual);
}

SolveStats solveRadiosity(const RadiositySystem& sys, std::vector<glm::vec3>& b,
                          const SolveOptions& options,
                          const std::function<void(int, double)>& after_iteration,
                          Communicator* comm) {
  const Timer timer;
  SolveStats stats;
  PENUMBRA_CHECK(b.size() == sys.size());
  std::vector<glm::vec3> next(b.size());
  std::vector<double> row_residual(b.size(), 0.0);
  for (int k = 0; k < options.max_iterations; ++k) {
    // Each rank its rows; then every rank has all of B and of the residuals, in row order.
    if (options.solver == MatrixSolver::kJacobi) {
      jacobiRows(sys, b, next, row_residual);
      b.swap(next);
    } else {
      gaussSeidelRows(sys, b, row_residual);
    }
    completeRows<glm::vec3>(sys, comm, b);
    completeRows<double>(sys, comm, row_residual);
    const double r = meanOf(row_residual);
    stats.history.push_back(r);  // residual of iterate k
    ++stats.iterations;
    if (after_iteration) after_iteration(k, r);
    if (r <= options.tolerance) break;
  }
  stats.residual = meanSquaredResidual(sys, b, comm);
  stats.history.push_back(stats.residual);
  stats.converged = stats.residual <= options.tolerance;
  stats.seconds = timer.seconds();
  return stats;
}

}  // namespace penumbra
