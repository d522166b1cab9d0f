// Matrix radiosity's Jacobi iteration on the GPU (Carr, Hall, Hart 2003, sec. 3, eq. 4) against
// its CPU twin jacobiStep, the furnace's closed form and the CPU solver, on llvmpipe in CI.
#include "penumbra/radiosity/jacobi_gl.h"

#include "penumbra/core/check.h"
#include "penumbra/core/rng.h"
#include "penumbra/radiosity/matrix_radiosity.h"
#include "penumbra/scene/builtin.h"
#include "support/test_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <string>
#include <vector>

namespace penumbra {
namespace {

// The same form factors, materials and element count at another precision.
RadiositySystem withPrecision(const RadiositySystem& s, MatrixPrecision precision) {
  PENUMBRA_CHECK(s.precision() == MatrixPrecision::kFp32);
  RadiositySystem out(FormFactorMatrix{s.size(), s.f32()}, precision);
  out.reflectance = s.reflectance;
  out.emission = s.emission;
  return out;
}

// The cornell box as about 400 clusters of the hierarchy; its
// form factors are computed once.
const RadiositySystem& cornellSystem(MatrixPrecision precision) {
  static const RadiositySystem fp32 = [] {
    Expected<Scene> cornell = builtinScene("cornell");
    PENUMBRA_CHECK(cornell.ok());
    MatrixRadiosityOptions o;
    o.elements = 400;
    Expected<MatrixRadiosity> mr = buildMatrixRadiosity(*cornell, o);
    PENUMBRA_CHECK(mr.ok());
    return std::move(*mr->system);
  }();
  static const RadiositySystem fp16 = withPrecision(fp32, MatrixPrecision::kFp16);
  return precision == MatrixPrecision::kFp32 ? fp32 : fp16;
}

// A random system of n elements: rows of F sum to between 0.5 and 0.99 and have a non-zero
// diagonal (so diag(M) != I), reflectances in [0.1, 0.9], a tenth of the elements emit.
RadiositySystem randomSystem(uint32_t n, MatrixPrecision precision, uint64_t seed) {
  Rng rng(seed, 7);
  FormFactorMatrix f{n, std::vector<float>(size_t(n) * n)};
  for (uint32_t i = 0; i < n; ++i) {
    double sum = 0.0;
    for (uint32_t j = 0; j < n; ++j) {
      const float u = rng.uniform();
      f.f[size_t(i) * n + j] = u * u;  // a spread of magnitudes
      sum += u * u;
    }
    const double target = 0.5 + 0.49 * rng.uniform();
    for (uint32_t j = 0; j < n; ++j) {
      f.f[size_t(i) * n + j] = float(f.f[size_t(i) * n + j] * target / std::max(sum, 1e-9));
    }
  }
  RadiositySystem s(std::move(f), precision);
  for (uint32_t i = 0; i < n; ++i) {
    s.reflectance[i] = glm::vec3(0.1f + 0.8f * rng.uniform(), 0.1f + 0.8f * rng.uniform(),
                                 0.1f + 0.8f * rng.uniform());
    if (i % 10 == 3 || n < 10) {
      s.emission[i] = glm::vec3(1.0f + 9.0f * rng.uniform(), 1.0f + 9.0f * rng.uniform(),
                                1.0f + 9.0f * rng.uniform());
    }
  }
  return s;
}

// Largest |gpu - cpu| / |cpu| over elements and channels (0 where both are 0).
double maxRelativeDifference(const std::vector<glm::vec3>& gpu, const std::vector<glm::vec3>& cpu) {
  double worst = 0.0;
  for (size_t i = 0; i < cpu.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      const double d = std::fabs(double(gpu[i][c]) - double(cpu[i][c]));
      if (d == 0.0) continue;
      worst = std::max(worst, d / std::max(std::fabs(double(cpu[i][c])), 1e-30));
    }
  }
  return worst;
}

// The residual is a difference of nearly equal numbers once B nears the solution: the devices
// sum F B in different orders, each to about 1e-7 relative, so each element's (M B - E)_i may
// differ by s_i = 1e-6 (|B_i| + |E_i|). Mean squared residuals r then differ by at most
// 2 sqrt(r f) + f with f = mean s_i^2: the allowance is 1e-5 relative plus that rounding term,
// which only matters once r is small.
double residualTolerance(const std::vector<glm::vec3>& b, const RadiositySystem& s, double r) {
  double f = 0.0;
  for (size_t i = 0; i < b.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      const double si = 1e-6 * (std::fabs(double(b[i][c])) + std::fabs(double(s.emission[i][c])));
      f += si * si;
    }
  }
  f /= 3.0 * double(std::max<size_t>(1, b.size()));
  return 1e-5 * r + 2.0 * std::sqrt(r * f) + f;
}

// Mean over elements and channels of E^2: the scale of the residuals.
double meanSquaredEmission(const RadiositySystem& s) {
  double e2 = 0.0;
  for (const glm::vec3& e : s.emission) e2 += double(e.x * e.x + e.y * e.y + e.z * e.z);
  return e2 / (3.0 * double(std::max<size_t>(1, s.emission.size())));
}

struct Agreement {
  double b = 0.0;               // worst relative difference of B over all iterations
  double residual_early = 0.0;  // ... of the residuals >= 1e-4 mean E^2
  double residual = 0.0;        // worst relative difference of the residuals, all iterations
  double last_residual = 0.0;
};

// Runs `iterations` Jacobi steps from B = 0 on both devices, independently, and compares B
// after every step and the residuals every step returns.
Agreement compareIterations(const RadiositySystem& s, int iterations, const std::string& what) {
  Agreement a;
  Expected<GlJacobi> gpu = GlJacobi::create(s);
  EXPECT_TRUE(gpu.ok()) << what << ": " << (gpu.ok() ? "" : gpu.error().describe());
  if (!gpu.ok()) return a;
  std::vector<glm::vec3> cpu_b(s.size(), glm::vec3(0.0f)), cpu_next(s.size()), gpu_b;
  EXPECT_TRUE(gpu->upload(cpu_b).ok());
  for (int k = 0; k < iterations; ++k) {
    const double r_cpu = jacobiStep(s, cpu_b, cpu_next);
    const double r_tolerance = residualTolerance(cpu_b, s, r_cpu);  // of iterate k
    cpu_b.swap(cpu_next);
    Expected<double> r_gpu = gpu->step();
    EXPECT_TRUE(r_gpu.ok()) << what;
    if (!r_gpu.ok()) return a;
    EXPECT_TRUE(gpu->download(gpu_b).ok());
    const double d = maxRelativeDifference(gpu_b, cpu_b);
    a.b = std::max(a.b, d);
    EXPECT_LT(d, 1e-5) << what << " iteration " << k;
    const double rd = r_cpu > 0.0 ? std::fabs(*r_gpu - r_cpu) / r_cpu : 0.0;
    a.residual = std::max(a.residual, rd);
    if (r_cpu >= 1e-4 * meanSquaredEmission(s)) a.residual_early = std::max(a.residual_early, rd);
    a.last_residual = r_cpu;
    EXPECT_LE(std::fabs(*r_gpu - r_cpu), r_tolerance)
        << what << " iteration " << k << ": gpu " << *r_gpu << " cpu " << r_cpu;
  }
  std::printf(
      "[ agreement ] %s, %d iterations: B max rel diff %.3g; residual max rel diff %.3g while "
      ">= 1e-4 mean E^2, %.3g over all (last residual %.3g mean E^2)\n",
      what.c_str(), iterations, a.b, a.residual_early, a.residual,
      a.last_residual / meanSquaredEmission(s));
  return a;
}

TEST(GlJacobi, MatchesCpuJacobiAfterEveryIterationOnCornell) {
  PENUMBRA_GL_OR_SKIP();
  for (MatrixPrecision p : {MatrixPrecision::kFp32, MatrixPrecision::kFp16}) {
    const RadiositySystem& s = cornellSystem(p);
    // More than one column block, the last one partial.
    ASSERT_GT(s.size(), kJacobiBlockColumns);
    ASSERT_LE(s.size(), 1000u);
    ASSERT_NE(s.size() % kJacobiBlockColumns, 0u);
    compareIterations(s, 30,
                      fmt::format("cornell {} elements {}", s.size(), matrixPrecisionName(p)));
  }
}

TEST(GlJacobi, MatchesCpuJacobiOnRandomSystemsOfSizesNotMultiplesOfTheBlock) {
  PENUMBRA_GL_OR_SKIP();
  // 1 and 7: fewer columns than a block and rows than a tile; 301: odd (a padded fp16 row);
  // 517: three column blocks, the last with 5 columns.
  for (uint32_t n : {1u, 7u, 301u, 517u}) {
    for (MatrixPrecision p : {MatrixPrecision::kFp32, MatrixPrecision::kFp16}) {
      const RadiositySystem s = randomSystem(n, p, n);
      compareIterations(s, 30, fmt::format("random N={} {}", n, matrixPrecisionName(p)));
    }
  }
}

// The furnace: a closed cube, rho = 0.5 and emitted radiance 1 everywhere, so every element's
// radiosity is E / (1 - rho) = 2 pi.
TEST(GlJacobi, FurnaceMatchesTheClosedForm) {
  PENUMBRA_GL_OR_SKIP();
  Expected<Scene> furnace = builtinScene("furnace");
  ASSERT_TRUE(furnace.ok());
  MatrixRadiosityOptions o;
  o.elements = 400;
  Expected<MatrixRadiosity> mr = buildMatrixRadiosity(*furnace, o);
  ASSERT_TRUE(mr.ok());
  for (MatrixPrecision p : {MatrixPrecision::kFp32, MatrixPrecision::kFp16}) {
    const RadiositySystem s = withPrecision(*mr->system, p);
    Expected<GlJacobi> gpu = GlJacobi::create(s);
    ASSERT_TRUE(gpu.ok()) << gpu.error().describe();
    std::vector<glm::vec3> b(s.size(), glm::vec3(0.0f));
    SolveOptions so;
    so.solver = MatrixSolver::kJacobi;
    so.tolerance = 1e-10;
    so.max_iterations = 300;
    Expected<SolveStats> st = gpu->solve(b, so);
    ASSERT_TRUE(st.ok()) << st.error().describe();
    EXPECT_TRUE(st->converged) << matrixPrecisionName(p) << " residual " << st->residual;
    const double expected = 2.0 * std::numbers::pi;
    double worst = 0.0;
    for (size_t k = 0; k < b.size(); ++k) {
      if (s.emission[k].x == 0.0f) continue;  // the walls' outsides
      for (int c = 0; c < 3; ++c) worst = std::max(worst, std::fabs(b[k][c] / expected - 1.0));
    }
    EXPECT_LT(worst, 0.005) << matrixPrecisionName(p);
    // And the CPU twin reaches the same B (so a miss above is the system's, not the device's).
    std::vector<glm::vec3> b_cpu(s.size(), glm::vec3(0.0f));
    const SolveStats cpu = solveRadiosity(s, b_cpu, so);
    EXPECT_EQ(st->iterations, cpu.iterations) << matrixPrecisionName(p);
    const double d = maxRelativeDifference(b, b_cpu);
    EXPECT_LT(d, 1e-5) << matrixPrecisionName(p);
    std::printf(
        "[ furnace   ] %u elements %s: %d iterations, worst |B / 2pi - 1| = %.3g, "
        "B max rel diff to the CPU %.3g\n",
        s.size(), matrixPrecisionName(p), st->iterations, worst, d);
  }
}

// solve() has solveRadiosity's semantics: history[k] is the residual of iterate k, the final
// residual of the returned B is appended, the same iteration count and flag.
TEST(GlJacobi, SolveKeepsTheCpuSolversHistoryAndStoppingRule) {
  PENUMBRA_GL_OR_SKIP();
  const RadiositySystem s = randomSystem(301, MatrixPrecision::kFp32, 5);
  Expected<GlJacobi> gpu = GlJacobi::create(s);
  ASSERT_TRUE(gpu.ok()) << gpu.error().describe();
  SolveOptions so;
  so.solver = MatrixSolver::kJacobi;
  for (double tolerance : {0.0, 1e-6}) {  // the iteration cap, then convergence
    for (int cap : {0, 1, 2, 40}) {
      so.tolerance = tolerance;
      so.max_iterations = cap;
      std::vector<glm::vec3> b_cpu(s.size(), glm::vec3(0.0f)), b_gpu = b_cpu;
      std::vector<int> seen_cpu, seen_gpu;
      const SolveStats cpu =
          solveRadiosity(s, b_cpu, so, [&](int k, double) { seen_cpu.push_back(k); });
      Expected<SolveStats> g = gpu->solve(b_gpu, so, [&](int k, double) { seen_gpu.push_back(k); });
      ASSERT_TRUE(g.ok()) << g.error().describe();
      const std::string what = fmt::format("tolerance {} cap {}", tolerance, cap);
      EXPECT_EQ(g->iterations, cpu.iterations) << what;
      EXPECT_EQ(g->converged, cpu.converged) << what;
      EXPECT_EQ(seen_gpu, seen_cpu) << what;
      ASSERT_EQ(g->history.size(), cpu.history.size()) << what;
      ASSERT_EQ(g->history.size(), size_t(g->iterations) + 1) << what;
      for (size_t k = 0; k < cpu.history.size(); ++k) {
        const double r = cpu.history[k];
        EXPECT_LE(std::fabs(g->history[k] - r), residualTolerance(b_cpu, s, r))
            << what << " k " << k;
      }
      EXPECT_EQ(g->history.back(), g->residual) << what;
      EXPECT_LT(maxRelativeDifference(b_gpu, b_cpu), 1e-5) << what;
      // The final residual is the residual of the B returned.
      ASSERT_TRUE(gpu->upload(b_gpu).ok());
      Expected<double> r = gpu->residual();
      ASSERT_TRUE(r.ok());
      EXPECT_EQ(*r, g->residual) << what;
    }
  }
}

// Dynamic relighting (sec. 1, 3): new emission and reflectance, F stays on the GPU, and the
// warm-started GPU solve matches a CPU solve of the same system from the same start.
TEST(GlJacobi, RelightingWarmStartMatchesCpuSolve) {
  PENUMBRA_GL_OR_SKIP();
  for (MatrixPrecision p : {MatrixPrecision::kFp32, MatrixPrecision::kFp16}) {
    RadiositySystem s = withPrecision(cornellSystem(MatrixPrecision::kFp32), p);
    Expected<GlJacobi> gpu = GlJacobi::create(s);
    ASSERT_TRUE(gpu.ok()) << gpu.error().describe();
    SolveOptions so;
    so.solver = MatrixSolver::kJacobi;
    so.tolerance = 1e-9 * meanSquaredEmission(s);  // the residual is in (W m^-2)^2
    so.max_iterations = 300;
    std::vector<glm::vec3> b_gpu(s.size(), glm::vec3(0.0f));
    Expected<SolveStats> first = gpu->solve(b_gpu, so);
    ASSERT_TRUE(first.ok() && first->converged);

    // The light turns warm and twice as bright; a tenth of the elements glow blue; the
    // reflectances darken by a fifth.
    for (uint32_t i = 0; i < s.size(); ++i) {
      s.emission[i] *= glm::vec3(2.0f, 1.5f, 0.8f);
      if (i % 10 == 0) s.emission[i] += glm::vec3(0.0f, 0.0f, 3.0f);
      s.reflectance[i] *= 0.8f;
    }
    ASSERT_TRUE(gpu->setMaterials(s.reflectance, s.emission).ok());
    std::vector<glm::vec3> b_cpu = b_gpu;  // the same warm start
    const SolveStats cpu = solveRadiosity(s, b_cpu, so);
    Expected<SolveStats> relit = gpu->solve(b_gpu, so);
    ASSERT_TRUE(relit.ok()) << relit.error().describe();
    EXPECT_TRUE(cpu.converged && relit->converged);
    EXPECT_NEAR(relit->iterations, cpu.iterations, 1) << matrixPrecisionName(p);
    const double d = maxRelativeDifference(b_gpu, b_cpu);
    EXPECT_LT(d, 1e-5) << matrixPrecisionName(p);
    std::printf("[ relight   ] %s: cold %d iterations, warm gpu %d cpu %d, B max rel diff %.3g\n",
                matrixPrecisionName(p), first->iterations, relit->iterations, cpu.iterations, d);
  }
}

TEST(GlJacobi, RefusesAMatrixOverTheDeviceLimitWithAnError) {
  PENUMBRA_GL_OR_SKIP();
  const RadiositySystem s = randomSystem(301, MatrixPrecision::kFp32, 9);
  // A device allowing 256 KiB per storage block: the 301 x 301 fp32 matrix (354 KiB) is over.
  Expected<GlJacobi> refused = GlJacobi::create(s, 256 * 1024);
  ASSERT_FALSE(refused.ok());
  const std::string message = refused.error().describe();
  EXPECT_NE(message.find("GL_MAX_SHADER_STORAGE_BLOCK_SIZE"), std::string::npos) << message;
  EXPECT_NE(message.find("301 elements"), std::string::npos) << message;
  // In fp16 (177 KiB) the same system fits.
  const RadiositySystem h = randomSystem(301, MatrixPrecision::kFp16, 9);
  EXPECT_TRUE(GlJacobi::create(h, 256 * 1024).ok());

  // Gauss-Seidel is sequential (sec. 3): asked of the GPU, it is an error, not a silent Jacobi.
  Expected<GlJacobi> gpu = GlJacobi::create(h);
  ASSERT_TRUE(gpu.ok());
  std::vector<glm::vec3> b(h.size(), glm::vec3(0.0f));
  SolveOptions so;
  so.solver = MatrixSolver::kGaussSeidel;
  Expected<SolveStats> st = gpu->solve(b, so);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().describe().find("Jacobi"), std::string::npos);
}

}  // namespace
}  // namespace penumbra
