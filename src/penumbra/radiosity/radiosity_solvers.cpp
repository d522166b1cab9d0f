#include "penumbra/radiosity/radiosity_solvers.h"

#include "penumbra/radiosity/jacobi_gl.h"
#include "penumbra/radiosity/progressive_gl.h"
#include "penumbra/radiosity/stochastic_gl.h"

#include <fmt/format.h>

#include <optional>
#include <utility>

namespace penumbra {

const char* solverDeviceName(SolverDevice device) {
  return device == SolverDevice::kGpu ? "gpu" : "cpu";
}

Expected<MatrixSolver> matrixSolverFor(SolverDevice device, std::optional<MatrixSolver> requested) {
  const bool gpu = device == SolverDevice::kGpu;
  const MatrixSolver solver =
      requested.value_or(gpu ? MatrixSolver::kJacobi : MatrixSolver::kGaussSeidel);
  if (gpu && solver != MatrixSolver::kJacobi) {
    return inputError("", "--solver",
                      "gauss-seidel is sequential and runs on the CPU only (use --device cpu, "
                      "or --solver jacobi on the GPU)");
  }
  return solver;
}

namespace {

// ---- Matrix radiosity ----

class CpuMatrixSolver final : public MatrixRadiositySolver {
 public:
  explicit CpuMatrixSolver(MatrixRadiosity& system) : system_(system) {}
  SolverDevice device() const override { return SolverDevice::kCpu; }
  // applyMaterials / setLights changed the system the CPU iterates on.
  Status relight() override { return {}; }
  Expected<SolveStats> solve(const SolveOptions& options,
                             const std::function<void(int, double)>& after_iteration) override {
    return system_.solve(options, after_iteration);
  }

 private:
  MatrixRadiosity& system_;
};

class GpuMatrixSolver final : public MatrixRadiositySolver {
 public:
  GpuMatrixSolver(MatrixRadiosity& system, GlJacobi jacobi)
      : system_(system), jacobi_(std::move(jacobi)) {}
  SolverDevice device() const override { return SolverDevice::kGpu; }
  Status relight() override {
    return jacobi_.setMaterials(system_.system->reflectance, system_.system->emission);
  }
  Expected<SolveStats> solve(const SolveOptions& options,
                             const std::function<void(int, double)>& after_iteration) override {
    PENUMBRA_TRY(matrixSolverFor(SolverDevice::kGpu, options.solver));
    return jacobi_.solve(system_.radiosity, options, after_iteration);
  }

 private:
  MatrixRadiosity& system_;
  GlJacobi jacobi_;
};

// ---- Progressive radiosity ----

class CpuProgressiveSolver final : public ProgressiveSolver {
 public:
  explicit CpuProgressiveSolver(ProgressiveRadiosity& cpu) : cpu_(cpu) {}
  SolverDevice device() const override { return SolverDevice::kCpu; }
  Expected<ProgressiveIteration> step() override { return cpu_.step(); }
  Expected<ProgressiveStats> solve(
      const std::function<void(const ProgressiveIteration&)>& after_iteration,
      const std::function<bool()>& stop) override {
    return cpu_.solve(after_iteration, stop);
  }
  Status sync() override { return {}; }
  Expected<Image> radianceImage() override { return cpu_.radianceImage(false); }

 private:
  ProgressiveRadiosity& cpu_;
};

class GpuProgressiveSolver final : public ProgressiveSolver {
 public:
  GpuProgressiveSolver(ProgressiveRadiosity& cpu, GlProgressive gl,
                       std::optional<ProgressiveIteration> lights)
      : cpu_(cpu), gl_(std::move(gl)), lights_(std::move(lights)) {}
  SolverDevice device() const override { return SolverDevice::kGpu; }
  Expected<ProgressiveIteration> step() override { return gl_.step(); }
  Expected<ProgressiveStats> solve(
      const std::function<void(const ProgressiveIteration&)>& after_iteration,
      const std::function<bool()>& stop) override {
    // The lights' iteration the CPU made before the upload is this solve's first.
    if (lights_ && after_iteration) after_iteration(*lights_);
    lights_.reset();
    return gl_.solve(after_iteration, stop);
  }
  Status sync() override {
    Expected<ProgressiveState> state = gl_.download();
    if (!state) return state.error();
    return cpu_.setState(std::move(*state));
  }
  // Through the GPU's own post-process (sec. 3.1).
  Expected<Image> radianceImage() override { return gl_.radianceImage(); }

 private:
  ProgressiveRadiosity& cpu_;
  GlProgressive gl_;
  std::optional<ProgressiveIteration> lights_;
};

// ---- Stochastic radiosity ----

class CpuStochasticSolver final : public StochasticSolver {
 public:
  explicit CpuStochasticSolver(StochasticRadiosity& cpu) : cpu_(cpu) {}
  SolverDevice device() const override { return SolverDevice::kCpu; }
  Expected<StochasticIteration> step() override { return cpu_.step(); }
  Expected<StochasticStats> solve(
      const std::function<void(const StochasticIteration&)>& after_iteration,
      const std::function<bool()>& stop) override {
    return cpu_.solve(after_iteration, stop);
  }
  int averaged() const override { return cpu_.averaged(); }
  Expected<double> errorEstimate() override { return cpu_.errorEstimate(); }
  Status sync() override { return {}; }

 private:
  StochasticRadiosity& cpu_;
};

class GpuStochasticSolver final : public StochasticSolver {
 public:
  GpuStochasticSolver(StochasticRadiosity& cpu, GlStochastic gl) : cpu_(cpu), gl_(std::move(gl)) {}
  SolverDevice device() const override { return SolverDevice::kGpu; }
  Expected<StochasticIteration> step() override { return gl_.step(); }
  Expected<StochasticStats> solve(
      const std::function<void(const StochasticIteration&)>& after_iteration,
      const std::function<bool()>& stop) override {
    return gl_.solve(after_iteration, stop);
  }
  int averaged() const override { return gl_.averaged(); }
  Expected<double> errorEstimate() override { return gl_.errorEstimate(); }
  Status sync() override {
    Expected<StochasticState> state = gl_.download();
    if (!state) return state.error();
    return cpu_.setState(std::move(*state));
  }

 private:
  StochasticRadiosity& cpu_;
  GlStochastic gl_;
};

}  // namespace

Expected<std::unique_ptr<MatrixRadiositySolver>> MatrixRadiositySolver::create(
    MatrixRadiosity& system, SolverDevice device) {
  if (device == SolverDevice::kCpu) return {std::make_unique<CpuMatrixSolver>(system)};
  Expected<GlJacobi> jacobi = GlJacobi::create(*system.system);
  if (!jacobi) return jacobi.error();
  return {std::make_unique<GpuMatrixSolver>(system, std::move(*jacobi))};
}

Expected<std::unique_ptr<ProgressiveSolver>> ProgressiveSolver::create(ProgressiveRadiosity& cpu,
                                                                       SolverDevice device) {
  if (device == SolverDevice::kCpu) return {std::make_unique<CpuProgressiveSolver>(cpu)};
  // Point, spot and directional lights shoot first, on the CPU (ray-traced shadows); the GPU
  // continues from that state.
  std::optional<ProgressiveIteration> lights;
  if (!cpu.lightsShot()) lights = cpu.shoot(ProgressiveRadiosity::kLights);
  Expected<GlProgressive> gl = GlProgressive::create(cpu);
  if (!gl) return gl.error();
  return {std::make_unique<GpuProgressiveSolver>(cpu, std::move(*gl), std::move(lights))};
}

Expected<std::unique_ptr<StochasticSolver>> StochasticSolver::create(StochasticRadiosity& cpu,
                                                                     SolverDevice device) {
  if (device == SolverDevice::kCpu) return {std::make_unique<CpuStochasticSolver>(cpu)};
  Expected<GlStochastic> gl = GlStochastic::create(cpu);
  if (!gl) return gl.error();
  return {std::make_unique<GpuStochasticSolver>(cpu, std::move(*gl))};
}

}  // namespace penumbra
