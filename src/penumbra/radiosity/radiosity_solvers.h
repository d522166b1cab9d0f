// One solver interface per radiosity family, with a CPU and a GPU implementation behind each, so
// that `render`, `bake`, the live session and MPI runs drive the same objects and never branch on
// the device (design doc sec. 3):
//  - MatrixRadiositySolver (Carr, Hall, Hart 2003, sec. 3): Gauss-Seidel or Jacobi on the CPU
//    (MatrixRadiosity::solve), Jacobi on the GPU (GlJacobi), on the system MatrixRadiosity built;
//  - ProgressiveSolver (Wallner sec. 2): ProgressiveRadiosity on the CPU, GlProgressive on the
//    GPU;
//  - StochasticSolver (Barsi and Jakab): StochasticRadiosity on the CPU, GlStochastic on the GPU.
// Each family's CPU object holds the state between runs (checkpoints, statistics, bakes read it
// there): the GPU implementations start from it and copy their state back with sync().
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/radiosity/matrix_radiosity.h"
#include "penumbra/radiosity/progressive.h"
#include "penumbra/radiosity/stochastic.h"

#include <functional>
#include <memory>
#include <optional>
#include <string>

namespace penumbra {

enum class SolverDevice { kCpu, kGpu };
const char* solverDeviceName(SolverDevice device);

// The iteration `device` runs: `requested` when given, else the device's own (Gauss-Seidel on
// the CPU, which converges in about half the iterations, sec. 3; Jacobi on the GPU). Gauss-Seidel
// is sequential: asked of the GPU, an input error naming --solver.
Expected<MatrixSolver> matrixSolverFor(SolverDevice device,
                                       std::optional<MatrixSolver> requested = std::nullopt);

class MatrixRadiositySolver {
 public:
  // The solver of `system` on `device` (the GPU's needs a current OpenGL 4.5 context and uploads
  // F). `system` must outlive it, unmoved.
  static Expected<std::unique_ptr<MatrixRadiositySolver>> create(MatrixRadiosity& system,
                                                                 SolverDevice device);
  virtual ~MatrixRadiositySolver() = default;

  virtual SolverDevice device() const = 0;
  // Dynamic relighting (sec. 1, 3): after MatrixRadiosity::setLights / applyMaterials changed
  // the system's emission and reflectance, the solve uses them; F stays, and the current B is
  // the warm start.
  virtual Status relight() = 0;
  // Iterates from the current B (MatrixRadiosity::radiosity, which holds the result) per
  // `options`; `after_iteration(k, residual)` after each iteration. The GPU runs Jacobi only.
  virtual Expected<SolveStats> solve(
      const SolveOptions& options,
      const std::function<void(int, double)>& after_iteration = {}) = 0;
};

class ProgressiveSolver {
 public:
  // The solver over `cpu`'s state on `device`. The GPU's (GlProgressive) lets the CPU shoot the
  // point, spot and directional lights first (ray-traced shadows; reported as the first
  // iteration of its first solve), then uploads the state; it needs a current context. `cpu`
  // must outlive it, unmoved.
  static Expected<std::unique_ptr<ProgressiveSolver>> create(ProgressiveRadiosity& cpu,
                                                             SolverDevice device);
  virtual ~ProgressiveSolver() = default;

  virtual SolverDevice device() const = 0;
  // One iteration: the shooter with the largest unshot power shoots (eq. 6-8).
  virtual Expected<ProgressiveIteration> step() = 0;
  // Iterates until converged, the iteration cap or `stop()` (asked before each iteration);
  // `after_iteration` after each.
  virtual Expected<ProgressiveStats> solve(
      const std::function<void(const ProgressiveIteration&)>& after_iteration = {},
      const std::function<bool()>& stop = {}) = 0;
  // The solution into the CPU object (for checkpoints, statistics and bakes).
  virtual Status sync() = 0;
  // Outgoing radiance B / pi per lightmap texel, gaps filled (sec. 3.1).
  virtual Expected<Image> radianceImage() = 0;
};

class StochasticSolver {
 public:
  // The solver over `cpu`'s state on `device` (the GPU's needs a current context). `cpu` must
  // outlive it, unmoved.
  static Expected<std::unique_ptr<StochasticSolver>> create(StochasticRadiosity& cpu,
                                                            SolverDevice device);
  virtual ~StochasticSolver() = default;

  virtual SolverDevice device() const = 0;
  // One iteration (options.shooters random operators), the same on either device.
  virtual Expected<StochasticIteration> step() = 0;
  // Iterates until the iteration cap, the time limit or `stop()`.
  virtual Expected<StochasticStats> solve(
      const std::function<void(const StochasticIteration&)>& after_iteration = {},
      const std::function<bool()>& stop = {}) = 0;
  // Iterations averaged so far (after the burn-in), and the running error estimate.
  virtual int averaged() const = 0;
  virtual Expected<double> errorEstimate() = 0;
  // The state into the CPU object (for checkpoints, statistics, bakes and the lightmap, which
  // StochasticRadiosity::radianceImage makes from it).
  virtual Status sync() = 0;
};

}  // namespace penumbra
