// Matrix radiosity solvers: the furnace's closed form, Jacobi against Gauss-Seidel, fp16.
#include "penumbra/radiosity/matrix_radiosity.h"
#include "penumbra/scene/builtin.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <cmath>
#include <cstdio>
#include <cstring>
#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace penumbra {
namespace {

TEST(Half, ConversionsMatchIeeeRoundToNearestEven) {
  // Every half round-trips.
  for (uint32_t h = 0; h < 65536; ++h) {
    const float f = halfToFloat(uint16_t(h));
    if (std::isnan(f)) continue;
    ASSERT_EQ(floatToHalf(f), uint16_t(h)) << h;
  }
  // Ties and neighbours, against the hardware where there is F16C.
  const float cases[] = {0.0f,
                         1.0f,
                         1.0f + 0x1p-11f,
                         1.0f + 0x1p-11f + 0x1p-20f,
                         65504.0f,
                         65520.0f,
                         0x1p-24f,
                         0x1p-25f,
                         0x1.8p-25f,
                         0x1p-14f,
                         0.1f,
                         0.199823f,
                         1e-7f,
                         3e-5f};
  for (float c : cases) {
#if defined(__x86_64__) && defined(__F16C__)
    EXPECT_EQ(floatToHalf(c), _cvtss_sh(c, 0)) << c;
    EXPECT_EQ(floatToHalf(-c), _cvtss_sh(-c, 0)) << c;
#endif
    if (c < 65504.0f) {
      EXPECT_NEAR(halfToFloat(floatToHalf(c)), c, std::fabs(c) * 0x1p-11f + 0x1p-25f);
    }
  }
  EXPECT_EQ(floatToHalf(65520.0f), 0x7c00u);  // rounds to infinity
  EXPECT_EQ(floatToHalf(0x1p-25f), 0u);       // tie to even: zero
}

MatrixRadiosity furnaceSystem(MatrixPrecision precision, uint32_t elements) {
  Expected<Scene> furnace = builtinScene("furnace");
  EXPECT_TRUE(furnace.ok());
  MatrixRadiosityOptions o;
  o.elements = elements;
  o.precision = precision;
  Expected<MatrixRadiosity> mr = buildMatrixRadiosity(*furnace, o);
  EXPECT_TRUE(mr.ok());
  return std::move(*mr);
}

// The furnace: a closed cube, rho = 0.5 and emitted radiance 1 everywhere, so every element's
// radiosity is E / (1 - rho) = 2 pi (inside; the closed rows sum to 1).
TEST(MatrixRadiosity, FurnaceMatchesTheClosedFormWithBothSolvers) {
  for (MatrixPrecision precision : {MatrixPrecision::kFp32, MatrixPrecision::kFp16}) {
    MatrixRadiosity mr = furnaceSystem(precision, 600);
    for (MatrixSolver solver : {MatrixSolver::kJacobi, MatrixSolver::kGaussSeidel}) {
      mr.radiosity.assign(mr.size(), glm::vec3(0.0f));
      SolveOptions so;
      so.solver = solver;
      so.tolerance = 1e-10;
      so.max_iterations = 200;
      const SolveStats st = mr.solve(so);
      EXPECT_TRUE(st.converged) << matrixSolverName(solver);
      const double expected = 2.0 * std::numbers::pi;
      double worst = 0.0;
      for (size_t k = 0; k < mr.size(); ++k) {
        // The walls' outsides (two-sided) neither emit nor receive.
        if (mr.system->emission[k].x == 0.0f) {
          EXPECT_EQ(mr.radiosity[k], glm::vec3(0.0f));
          continue;
        }
        const glm::vec3 b = mr.radiosity[k];
        for (int c = 0; c < 3; ++c) worst = std::max(worst, std::fabs(b[c] / expected - 1.0));
      }
      EXPECT_LT(worst, 0.005) << matrixSolverName(solver) << " " << matrixPrecisionName(precision);
    }
  }
}

TEST(MatrixRadiosity, JacobiAndGaussSeidelReachTheSameSolutionAndResidualsFall) {
  Expected<Scene> cornell = builtinScene("cornell");
  ASSERT_TRUE(cornell.ok());
  MatrixRadiosityOptions o;
  o.elements = 500;
  Expected<MatrixRadiosity> mr = buildMatrixRadiosity(*cornell, o);
  ASSERT_TRUE(mr.ok());
  SolveOptions so;
  so.tolerance = 1e-12;
  so.max_iterations = 300;
  so.solver = MatrixSolver::kJacobi;
  const SolveStats jacobi = mr->solve(so);
  const std::vector<glm::vec3> bj = mr->radiosity;
  mr->radiosity.assign(bj.size(), glm::vec3(0.0f));
  so.solver = MatrixSolver::kGaussSeidel;
  const SolveStats gs = mr->solve(so);
  ASSERT_TRUE(jacobi.converged && gs.converged);
  for (size_t e = 0; e < bj.size(); ++e) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(mr->radiosity[e][c], bj[e][c], 1e-4 * (1.0 + std::fabs(bj[e][c])));
    }
  }
  // Residual histories fall monotonically (both iterations contract here: rho < 1, rows sum
  // to at most 1).
  for (const SolveStats* s : {&jacobi, &gs}) {
    for (size_t k = 1; k + 1 < s->history.size(); ++k) {
      EXPECT_LE(s->history[k], s->history[k - 1] * (1.0 + 1e-9));
    }
  }
  // The reported residual is that of the returned solution.
  EXPECT_NEAR(meanSquaredResidual(*mr->system, mr->radiosity), gs.residual,
              1e-15 + gs.residual * 1e-6);
}

// Dynamic relighting: new emissions and reflectances re-solved from the previous solution with
// the same form factors give the cold solution of the new system, in fewer iterations when the
// change is small.
TEST(MatrixRadiosity, RelightingFromThePreviousSolutionMatchesAColdSolve) {
  Expected<Scene> cornell = builtinScene("cornell");
  ASSERT_TRUE(cornell.ok());
  MatrixRadiosityOptions o;
  o.elements = 400;
  Expected<MatrixRadiosity> mr = buildMatrixRadiosity(*cornell, o);
  ASSERT_TRUE(mr.ok());
  SolveOptions so;
  so.tolerance = 1e-10;
  ASSERT_TRUE(mr->solve(so).converged);
  const std::vector<float> before = mr->system->f32();
  // Dim the light by 10% and make the red wall a little redder.
  std::vector<Material> materials = cornell->materials;
  for (Material& m : materials) {
    if (m.isEmissive()) m.emission *= 0.9f;
    if (m.name == "red") m.reflectance.x = 0.7f;
  }
  mr->applyMaterials(materials);
  const SolveStats warm = mr->solve(so);
  const std::vector<glm::vec3> relit = mr->radiosity;
  mr->radiosity.assign(relit.size(), glm::vec3(0.0f));
  const SolveStats cold = mr->solve(so);
  ASSERT_TRUE(warm.converged && cold.converged);
  EXPECT_LT(warm.iterations, cold.iterations);
  EXPECT_EQ(mr->system->f32(), before);  // the form factors were not touched
  for (size_t e = 0; e < relit.size(); ++e) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(relit[e][c], mr->radiosity[e][c], 1e-4 * (1.0 + std::fabs(relit[e][c])));
    }
  }
}

// fp16 storage of the form factors (as the paper stores its link factors): the solution moves
// by the half's rounding, far below the discretisation error (measured: 4.5e-6 relative RMS,
// 1.9e-4 at the worst element, on the Cornell box).
TEST(MatrixRadiosity, Fp16StorageMovesTheCornellSolutionByLessThan1e4Rms) {
  Expected<Scene> cornell = builtinScene("cornell");
  ASSERT_TRUE(cornell.ok());
  MatrixRadiosityOptions o;
  o.elements = 1000;
  Expected<MatrixRadiosity> mr32 = buildMatrixRadiosity(*cornell, o);
  o.precision = MatrixPrecision::kFp16;
  Expected<MatrixRadiosity> mr16 = buildMatrixRadiosity(*cornell, o);
  ASSERT_TRUE(mr32.ok() && mr16.ok());
  SolveOptions so;
  so.tolerance = 1e-12;
  ASSERT_TRUE(mr32->solve(so).converged && mr16->solve(so).converged);
  double err = 0.0, norm = 0.0, worst = 0.0;
  for (size_t e = 0; e < mr32->radiosity.size(); ++e) {
    const glm::dvec3 a(mr32->radiosity[e]), b(mr16->radiosity[e]);
    err += glm::dot(a - b, a - b);
    norm += glm::dot(a, a);
    for (int c = 0; c < 3; ++c) worst = std::max(worst, std::fabs(a[c] - b[c]) / (a[c] + 1e-3));
  }
  const double rms = std::sqrt(err / norm);
  std::printf("fp16 vs fp32 on the Cornell box: relative RMS %.2e, worst element %.2e\n", rms,
              worst);
  EXPECT_LT(rms, 1e-4);    // measured 4.5e-6
  EXPECT_GT(rms, 0.0);     // the storage really is different
  EXPECT_LT(worst, 1e-3);  // measured 1.9e-4
}

}  // namespace
}  // namespace penumbra
