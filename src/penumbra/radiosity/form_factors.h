// The form-factor matrix F of matrix radiosity (Carr, Hall, Hart 2003, eq. 1), with visibility
// from the Ray Engine: F_ij is the fraction of the light leaving element i that arrives at
// element j, i.e. (1 / A_i) * integral over x in i of F(dA_x -> A_j) V(x, j) dA_x.
//
// Two estimators:
//  - kPointPolygon (the default): at S stratified points x_s of element i, Lambert's exact
//    point-to-polygon form factor to element j (kernels/form_factor.h), times the visibility
//    of one ray from x_s to a stratified point of j. The inner integral over j is exact, so
//    there is no 1/r^2 singularity between neighbouring elements (which share edges in every
//    corner of a room), and in an unoccluded closed scene every row sums to 1 up to rounding;
//    what remains random is only the visibility estimate.
//  - kMonteCarlo: the area-to-area estimator, A_j times the mean of cos cos V / (pi r^2) over S
//    random point pairs. Unbiased, but its variance grows without bound as elements touch;
//    kept as the textbook reference and for comparison.
//
// Elements are one-sided (elements.h): F_ij = 0 where j's front face does not face x, and the
// polygon is clipped to the hemisphere above i.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/radiosity/elements.h"

#include <cstdint>
#include <functional>
#include <vector>

namespace penumbra {

enum class FormFactorEstimator { kPointPolygon, kMonteCarlo };

struct FormFactorOptions {
  FormFactorEstimator estimator = FormFactorEstimator::kPointPolygon;
  // Points of element i per pair (rounded up to a square for stratification). Visibility takes
  // one ray per point for pairs closer than 4 times their sizes, one per 2 x 2 block of points
  // for farther pairs.
  int samples = 16;
  bool visibility = true;  // false: no rays, every pair treated as unoccluded
  uint64_t seed = 0;
};

// Row-major N x N: f[i * n + j] = F_ij.
struct FormFactorMatrix {
  uint32_t n = 0;
  std::vector<float> f;

  float operator()(uint32_t i, uint32_t j) const { return f[size_t(i) * n + j]; }
  double rowSum(uint32_t i) const;
};

struct FormFactorStats {
  double seconds = 0.0;
  uint64_t pairs = 0;  // element pairs evaluated (N^2 - N)
  uint64_t rays = 0;   // visibility rays traced
};

// Bytes of an N x N float matrix.
inline uint64_t formFactorBytes(uint64_t n) {
  return n * n * sizeof(float);
}

// Computes every F_ij (rows in parallel; the result does not depend on the thread count).
// Refuses, before allocating, a matrix that would not fit in memory. `on_row(rows_done)` may be
// called from worker threads.
Expected<FormFactorMatrix> computeFormFactors(const Elements& elements,
                                              const FormFactorOptions& options,
                                              FormFactorStats* stats = nullptr,
                                              const std::function<void(size_t)>& on_row = {});

}  // namespace penumbra
