// Matrix radiosity as a user runs it (Carr, Hall, Hart 2003, sec. 3): mesh the scene into
// elements, compute the form factors once, then solve, and solve again after emissions or
// reflectances change (dynamic relighting: the form factors, which hold all the geometry and
// visibility, are kept; the previous solution is the starting point).
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/radiosity/elements.h"
#include "penumbra/radiosity/form_factors.h"
#include "penumbra/radiosity/matrix_solver.h"
#include "penumbra/scene/scene.h"

#include <functional>
#include <optional>
#include <span>
#include <vector>

namespace penumbra {

struct MatrixRadiosityOptions {
  MeshingOptions meshing;
  FormFactorOptions form_factors;
  MatrixPrecision precision = MatrixPrecision::kFp32;
};

// Bytes the method needs for n elements at a precision (form factors in fp32 while they are
// computed, the stored matrix, the elements): checked before anything N^2 is allocated.
uint64_t matrixRadiosityBytes(uint64_t n, MatrixPrecision precision);

struct MatrixRadiosity {
  Elements elements;
  std::optional<RadiositySystem> system;  // always set once built
  std::vector<glm::vec3> radiosity;       // B per element (W m^-2), the latest solution
  // Irradiance from the point, spot and directional lights at each element's centroid, with a
  // Ray Engine shadow ray (W m^-2; radiosity/lights.h): the direct term.
  std::vector<glm::vec3> direct;
  FormFactorStats form_factor_stats;

  // Sets each element's reflectance and emission from the materials (emission is radiance,
  // so E = pi L_e for a Lambertian emitter), plus the lights' direct term reflected:
  // B = E + rho * direct + rho F B.
  void applyMaterials(std::span<const Material> materials);
  // Solves from the current `radiosity` (zeros at first, the previous solution afterwards).
  SolveStats solve(const SolveOptions& options,
                   const std::function<void(int, double)>& after_iteration = {});
  // Outgoing radiance (B / pi) at element corners, smooth across elements (sec. 3.1).
  std::vector<glm::vec3> cornerRadiance() const;
};

// Meshes the scene and computes the form factors (`on_row(rows_done, rows)` reports progress).
// Refuses, with the amount, a system that would not fit in memory.
Expected<MatrixRadiosity> buildMatrixRadiosity(
    const Scene& scene, const MatrixRadiosityOptions& options,
    const std::function<void(size_t, size_t)>& on_row = {});

}  // namespace penumbra
