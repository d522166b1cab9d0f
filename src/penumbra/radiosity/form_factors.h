// The form-factor matrix F of matrix radiosity (Carr, Hall, Hart 2003, eq. 1) between the
// clusters of a cut through the multiresolution hierarchy (geometry/surface_hierarchy.h), with
// visibility from the Ray Engine: F_ij is the fraction of the light leaving cluster i that
// arrives at cluster j, (1 / A_i) T_ij with the transport T_ij = integral over x in i of
// F(dA_x -> j) V(x, j) dA_x. The unknowns are as many clusters as the caller asks for, whatever
// the triangle count (the paper's multiresolution meshed atlas, sec. 4.2: samples independent of
// the tessellation; its sec. 5: gathering from clusters at the appropriate MIP level).
//
// T_ij is evaluated once per unordered pair, so A_i F_ij = A_j F_ji holds exactly (reciprocity):
//  - Far pairs (centres farther apart than `near` times the sum of the clusters' radii
//    sqrt(A / pi)): eq. 2 of Wallner with one disc each way, symmetrised,
//      T = A_i A_j c_i c_j (1 / (pi d^2 + A_j) + 1 / (pi d^2 + A_i)) / 2,
//    c = the cosine at each cluster's area-weighted mean normal times its flatness
//    |sum n A| / sum A (the projected area of a curved cluster), times the fraction of `rays`
//    shadow rays between points of the two clusters (elements chosen in strata of each
//    cluster's Morton range) that arrive; pairs that exchange little (F_ij and F_ji below
//    kFewRaysBelow) take one ray.
//  - Near pairs: the larger cluster is replaced by its children (hierarchical refinement), down
//    to elements; two elements that near exchange, at each one's point, Lambert's exact
//    point-to-polygon form factor to the other's pieces (kernels/form_factor.h), averaged both
//    ways, with one shadow ray between the points. There is no 1/r^2 singularity where surfaces
//    meet (every corner of a room).
//  - Clusters of the same planar chart exchange nothing; a cluster's light never returns to
//    itself (F_ii = 0).
//  - Closed rows: the approximations make a row's sum differ from 1 even where the cluster sees
//    only surfaces with elements. Each cluster sends `probe_rays` cosine-distributed rays (from
//    its elements, chosen by area); if every one hits a face with elements, its row is scaled to
//    sum to 1 (the form factors' sum rule), so energy is conserved in closed scenes. No row
//    sums to more than 1.
#pragma once

#include "penumbra/cluster/communicator.h"
#include "penumbra/core/expected.h"
#include "penumbra/geometry/surface_hierarchy.h"
#include "penumbra/radiosity/radiosity_surface.h"

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

namespace penumbra {

struct FormFactorOptions {
  bool visibility = true;  // false: no rays, every pair treated as unoccluded
  uint64_t seed = 0;
  double near = 2.0;      // pairs nearer than this many summed radii are refined
  int rays = 4;           // shadow rays for a far pair that exchanges a noticeable share
  int element_rays = 16;  // for every far pair of an element and an emitting cluster
  int probe_rays = 256;   // per cluster, for the closed-row test; 0: never normalise
};

// Far pairs whose F_ij and F_ji are both below this take a single shadow ray.
inline constexpr double kFewRaysBelow = 1e-3;

// Every element's pieces (the clip of its chart's faces to its texel, on the surface), clipped
// once: near element pairs ask for them many times. Element e's pieces are
// [piece_first[e], piece_first[e + 1]), piece p's corners [corner_first[p], corner_first[p + 1]).
// Empty (clip on demand) for more than kMaxElements elements, where it would take too much memory.
struct ElementPieces {
  std::vector<uint32_t> piece_first;
  std::vector<uint32_t> corner_first;
  std::vector<glm::dvec3> corners;

  static constexpr size_t kMaxElements = 200'000;
  static ElementPieces build(const RadiositySurface& surface);
  bool empty() const { return piece_first.empty(); }
};

// Row-major rows of the N x N matrix: f[(i - row_begin) * n + j] = F_ij for the rows held, all N
// on one process, a block of them on each rank of a distributed run (docs/scaling.md).
struct FormFactorMatrix {
  uint32_t n = 0;
  std::vector<float> f;
  // Per row held, the factor the closed-row rule (or the cap at 1) scaled it by (1: untouched).
  std::vector<float> row_scale;
  uint32_t row_begin = 0;  // the first row held

  uint32_t rowsHeld() const { return n == 0 ? 0 : uint32_t(f.size() / n); }
  uint32_t rowEnd() const { return row_begin + rowsHeld(); }
  float operator()(uint32_t i, uint32_t j) const { return f[size_t(i - row_begin) * n + j]; }
  double rowSum(uint32_t i) const;
};

struct FormFactorStats {
  double seconds = 0.0;
  uint64_t pairs = 0;        // cluster pairs (N (N - 1) / 2)
  uint64_t refined = 0;      // sub-pairs evaluated after refinement (element pairs included)
  uint64_t rays = 0;         // shadow and probe rays traced
  uint64_t closed_rows = 0;  // rows normalised to 1
};

// Bytes of an N x N float matrix.
inline uint64_t formFactorBytes(uint64_t n) {
  return n * n * sizeof(float);
}

// Computes every F_ij between the clusters of `cut` (rows in parallel; the result does not depend
// on the thread count). Refuses, before allocating, a matrix that would not fit in memory.
// `on_row(rows_done)` may be called from worker threads. `pieces`: ElementPieces::build(surface)
// when the caller has it (else built here).
//
// Over several ranks (`comm`, collective; docs/scaling.md), rank r holds the rows
// matrixRowBlock(n, r, size) and evaluates the pairs of the rows i = r mod size (a balanced share
// of the triangle j > i); each pair's two entries go to the ranks that hold their rows, in one
// exchange. Every entry is the one process's, bit for bit (a pair's random stream is its own).
// The memory guard counts this rank's rows. Stats are summed over the ranks.
Expected<FormFactorMatrix> computeFormFactors(const RadiositySurface& surface,
                                              std::span<const ClusterRef> cut,
                                              const FormFactorOptions& options,
                                              FormFactorStats* stats = nullptr,
                                              const std::function<void(size_t)>& on_row = {},
                                              const ElementPieces* pieces = nullptr,
                                              Communicator* comm = nullptr);

// The rows rank `rank` of `size` holds of an n-row system: contiguous, as even as whole groups of
// four rows allow.
Share matrixRowBlock(uint64_t n, int rank, int size);

// Form factors from every element (level 0) to the clusters cut[sources[s]]: out[e * S + s] =
// F(element e -> cluster), by the same rules (an element inside the cluster gets 0). What
// matrix radiosity gathers at full resolution from emitters (radiosity/matrix_radiosity.h).
// Rays traced are added to stats->rays. Over several ranks (`comm`, collective) each computes a
// share of the elements and all get every value.
Expected<std::vector<float>> computeElementFormFactors(const RadiositySurface& surface,
                                                       std::span<const ClusterRef> cut,
                                                       std::span<const uint32_t> sources,
                                                       const FormFactorOptions& options,
                                                       FormFactorStats* stats = nullptr,
                                                       const ElementPieces* pieces = nullptr,
                                                       Communicator* comm = nullptr);

}  // namespace penumbra
