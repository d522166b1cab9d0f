// Matrix radiosity solvers (Carr, Hall, Hart 2003, sec. 3, eq. 1-4), on the CPU.
//
// The system, per RGB channel: B_i = E_i + rho_i sum_j F_ij B_j (eq. 1), i.e. M B = E with
// M = I - diag(rho) F (eq. 2). The form factors are shared by the three channels, so the matrix
// stored is F (fp32, or fp16 as the paper stores its link factors) and one pass over it serves
// red, green and blue.
//
//  - Jacobi in the full matrix-vector form of eq. 4, B' = B + E - diag(M)^-1 M B (the paper's
//    GPU method: no j != i branch), rows in parallel, 8-wide vector dot products.
//  - Gauss-Seidel: B_i = (E_i + rho_i sum_{j != i} F_ij B_j) / (1 - rho_i F_ii), in place, row
//    after row (inherently sequential: one core, vectorised rows).
//
// Convergence is measured as in the paper's Fig. 3, by the mean squared residual of M B - E over
// elements and channels, in (W m^-2)^2: residual = mean_{i,c} (M B - E)_{i,c}^2. Both solvers
// get it without an extra pass: Jacobi's matrix-vector product is M B itself, and the
// Gauss-Seidel sweep accumulates, from the same reads of F, the row sums with the old B as well
// as with the updates made so far in the sweep.
#pragma once

#include "penumbra/radiosity/form_factors.h"

#include <glm/vec3.hpp>

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

namespace penumbra {

enum class MatrixSolver { kJacobi, kGaussSeidel };
enum class MatrixPrecision { kFp32, kFp16 };

const char* matrixSolverName(MatrixSolver solver);
const char* matrixPrecisionName(MatrixPrecision precision);

// IEEE 754 binary16 conversions (round to nearest even), as F16C does them.
uint16_t floatToHalf(float value);
float halfToFloat(uint16_t half);

class RadiositySystem {
 public:
  // Takes the form factors (square); reflectance and emission start at zero.
  RadiositySystem(FormFactorMatrix form_factors, MatrixPrecision precision);

  uint32_t size() const { return n_; }
  // The rows of F held (all on one process; a rank's block over several, docs/scaling.md).
  uint32_t rowBegin() const { return row_begin_; }
  uint32_t rowEnd() const { return row_begin_ + rows_; }
  MatrixPrecision precision() const { return precision_; }
  // The matrix as stored: row-major n x n, one of the two is non-empty.
  const std::vector<float>& f32() const { return f32_; }
  const std::vector<uint16_t>& f16() const { return f16_; }
  // F_ij as the solvers see it (after fp16 rounding when stored so), for a row held.
  float formFactor(uint32_t i, uint32_t j) const;
  // Bytes the stored matrix takes.
  uint64_t matrixBytes() const;

  // Per element; may be changed between solves (dynamic relighting: the form factors stay).
  std::vector<glm::vec3> reflectance;
  std::vector<glm::vec3> emission;

 private:
  uint32_t n_ = 0;
  uint32_t row_begin_ = 0, rows_ = 0;
  MatrixPrecision precision_;
  std::vector<float> f32_;
  std::vector<uint16_t> f16_;
};

struct SolveOptions {
  MatrixSolver solver = MatrixSolver::kGaussSeidel;
  int max_iterations = 500;
  double tolerance = 1e-6;  // stop when the mean squared residual ((W m^-2)^2) is below this
};

struct SolveStats {
  int iterations = 0;
  double residual = 0.0;        // of the returned B
  bool converged = false;       // residual <= tolerance
  std::vector<double> history;  // history[k]: residual of the k-th iterate (history[0]: start)
  double seconds = 0.0;
};

// Over several ranks (`comm`, collective; docs/scaling.md) each rank computes the rows it holds
// and the ranks exchange them: every rank gets all of the result. The per-row values are summed
// in row order, so Jacobi's iterates, residuals and iteration count are one process's bit for
// bit. Gauss-Seidel becomes block Gauss-Seidel: in place within a rank's rows, the other rows as
// they were when the sweep began (the same fixed point; iterates and count differ).

// (F B)_i per element: the irradiance each element gathers from the others (W m^-2).
std::vector<glm::dvec3> gatherIrradiance(const RadiositySystem& system,
                                         std::span<const glm::vec3> b,
                                         Communicator* comm = nullptr);

// Mean squared residual of M B - E over elements and channels ((W m^-2)^2).
double meanSquaredResidual(const RadiositySystem& system, std::span<const glm::vec3> b,
                           Communicator* comm = nullptr);

// One Jacobi iteration (eq. 4) on one process: writes B' to `next` and returns the residual of
// `b`.
double jacobiStep(const RadiositySystem& system, std::span<const glm::vec3> b,
                  std::span<glm::vec3> next);
// One Gauss-Seidel sweep in place on one process; returns the residual of `b` as it was before
// the sweep.
double gaussSeidelSweep(const RadiositySystem& system, std::span<glm::vec3> b);

// Iterates from `b` (the previous solution for a warm start, or anything: zeros, E) until the
// residual is below the tolerance or the iteration cap; `b` holds the result.
// `after_iteration(k, residual_of_iterate_k)` is called after each iteration.
SolveStats solveRadiosity(const RadiositySystem& system, std::vector<glm::vec3>& b,
                          const SolveOptions& options,
                          const std::function<void(int, double)>& after_iteration = {},
                          Communicator* comm = nullptr);

}  // namespace penumbra
