// Stochastic radiosity by perspective ray-bundle shooting (Barsi and Jakab), the CPU version, on
// the chart atlas and hierarchy that matrix and progressive radiosity share
// (radiosity/radiosity_surface.h). The radiance function lives in the lightmap: every occupied
// texel is an element, B = pi L per element (W m^-2 per RGB channel).
//
//  - Stochastic iteration (sec. 2): B_m = E' + T* B_{m-1}, with T* a random transport operator
//    whose expectation is the light-transport operator, and the estimate the running average of
//    the iterates, B~_m = (1/m) sum_{i=1..m} B_i (eq. 2); B_0 = E'.
//  - First shots (`first_shots`, the default): the strongest light is computed, not sampled.
//    Progressive radiosity's deterministic shot (progressive.h: clusters of shooter points,
//    Lambert's form factor near, shadow rays, closed shots) shoots in its own order, the lights
//    first, then the shooter with the most unshot power (the emitters, then the brightest
//    reflectors), until at most kStochasticFirstShotRest of the power is unshot or `first_shots`
//    shooters have shot. That leaves B_p received and dB unshot; the solution is
//    B = B_p - dB + Y with Y = dB + T Y (dB, plus all it will bring). The iteration solves for Y:
//    E' = dB, and the estimate is (B_p - dB) + B~. The random operator then carries a tenth of
//    the power, spread over the scene, instead of picking one texel of a lamp at a time.
//    With first_shots = 0 (the paper's scheme) E' is the surfaces' own emission plus what they
//    reflect of the point, spot, directional and luminaire lights' direct irradiance (rho
//    E_direct, with Ray Engine shadow rays) and of the sky's or the environment's (rho S,
//    radiosity/outside_light.h), and the emitters' light enters by the random operator, one
//    texel a shot. With first shots, the sky and the environment shoot with the lights, as
//    progressive radiosity shoots them (booked as emitted: the first shots' stopping fraction
//    counts them).
//  - The random operator (eq. 3, perspective ray-bundle shooting): a texel j of B_{m-1} is
//    chosen with probability P_j = lum(B_j) A_j / Phi, Phi = sum_i lum(B_i) A_i (lum: 0.3 R +
//    0.59 G + 0.11 B, sec. 3.1), and sends its radiosity to every element r that faces it:
//      (T* B)_r = rho_r B_j F_rj v(r, j) / P_j = rho_r (B_j / lum(B_j)) (Phi / A_j) F_rj v(r, j),
//    F_rj the form factor from r's point to texel j: Lambert's exact point-to-polygon form
//    factor to j's pieces within kStochasticNear of j's size, the disc of Wallner's eq. 2 beyond
//    (the progressive method's kernels), v one Ray Engine shadow ray between the two points.
//    E[T* B] = sum_j P_j (T* B | j) = T B: each iteration is unbiased given the one before.
//  - The local operator: T = L + R*, L the pairs nearer than kStochasticLocal of the shooter
//    texel's size, applied to the whole iterate every iteration (Lambert's form factor to the
//    texel's pieces and a shadow ray per pair, computed once), R* the random operator over the
//    pairs beyond. E[L B + R* B] = T B still, but a texel picked with probability P_j no longer
//    sends rho B_j F_rj / P_j to its touching neighbours: at a corner F_rj reaches 0.2-0.5, and
//    those rare, huge contributions were the estimate's worst noise (one Cornell box floor block
//    11% off at the defaults). The pairs are few: only where surfaces meet at an angle, or curve.
//  - Shooter selection (sec. 3.1) descends the hierarchy as the paper descends the mipmap: the
//    sums of lum(B) A per cluster level by level, a chart root picked from their running sum,
//    then at each level the child whose running sum passes the remaining random value, down to a
//    texel, with probability exactly its share of Phi.
//  - `shooters` > 1 averages that many independent operators per iteration (still unbiased).
//  - Deterministic for a seed: iteration m draws from a generator started at a mix of (seed, m);
//    the receivers' updates do not depend on the thread count.
//  - Error estimate: the iterates are summed in two halves (odd and even iterations); half the
//    difference of their means, relative RMS over the elements (luminance, area-weighted),
//    estimates the standard error of the average.
//  - Burn-in: E[B_i] = sum_{k<=i} T^k E' (each operator is unbiased given the iterate before),
//    short of the solution by T^(i+1) B, which falls at least as the largest reflectance's
//    powers. The average starts after `burn_in` iterates (by default the first at which that
//    is below 1e-3), so that its expectation is the solution to that precision at any length;
//    the paper's form of eq. 2, T* applied to the average itself, would leave a bias falling
//    only as m^-(1 - rho). The noise falls as 1/sqrt(m).
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/radiosity/radiosity_surface.h"
#include "penumbra/scene/scene.h"

#include <glm/vec3.hpp>

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

namespace penumbra {

// Pairs nearer than this many shooter texel sizes (sqrt of its area) take Lambert's exact form
// factor to the texel's pieces; farther ones eq. 2's disc (its error falls with the square of
// size / distance: under 1% from 8 sizes on, as in progressive radiosity).
inline constexpr double kStochasticNear = 8.0;
// Pairs nearer than this many shooter texel sizes exchange by the local operator, every
// iteration, deterministically (see the file comment), not by the random one.
inline constexpr double kStochasticLocal = 4.0;

// One entry of the local operator: receiver r gathers f B_j from element j (f: Lambert's form
// factor from r's point to j's pieces, 0 when a shadow ray finds them hidden).
struct StochasticLocalPair {
  uint32_t element;
  float factor;
};

// The default cap on the first shots (StochasticOptions::first_shots), and the unshot share of
// the power (luminance) at which they stop.
inline constexpr int kStochasticFirstShots = 32;
inline constexpr double kStochasticFirstShotRest = 0.1;

struct StochasticOptions {
  ChartAtlasOptions atlas;  // the texel density (or atlas resolution) sets the element size
  int iterations = 1000;    // the cap on iterations (counted over a resumed run's too)
  double time_limit = 0.0;  // seconds; 0: none
  int shooters = 1;         // independent shooters per iteration, averaged
  int burn_in = -1;         // iterates left out of the average; -1: from the reflectances
  // Shooters shot deterministically before the iteration, at most (see the file comment); 0:
  // none, the emitters' light by the random operator as in the paper.
  int first_shots = kStochasticFirstShots;
  uint64_t seed = 0;
  bool visibility = true;       // false: no shadow rays (every facing pair sees each other)
  bool shading_normals = true;  // the receiver's cosine takes the shading normals
};

struct StochasticIteration {
  int iteration = 0;
  uint32_t shooter = 0;  // the first shooter's element
  double power = 0.0;    // Phi of the iterate it shot from (W, luminance)
  uint64_t rays = 0;
  double seconds = 0.0;
};

struct StochasticStats {
  int iterations = 0;        // in this call
  int total_iterations = 0;  // including earlier ones
  double error = 0.0;        // the running error estimate (relative RMS)
  bool interrupted = false;
  bool timed_out = false;
  uint64_t rays = 0;
  double seconds = 0.0;
};

// The solver's state between iterations (a checkpoint's body): the current iterate, the sums of
// the averaged iterates by parity, and the iteration count. Element order is the solver's.
struct StochasticState {
  std::vector<glm::dvec3> iterate;
  std::vector<glm::dvec3> sum_odd, sum_even;
  int iterations = 0;
};

// The iteration loop both devices' solve() run: iterations until `options.iterations` (counted
// by `iterations`, a resumed run's included) or the time limit; `stop` before each (true: return
// now, interrupted), `after` after each. The error estimate is the caller's to fill in.
Expected<StochasticStats> iterateStochastic(
    const StochasticOptions& options, const std::function<int()>& iterations,
    const std::function<Expected<StochasticIteration>()>& step,
    const std::function<void(const StochasticIteration&)>& after,
    const std::function<bool()>& stop);

class StochasticRadiosity {
 public:
  // Builds the atlas over the scene's faces (the scene must have passed validateScene) and
  // computes E'. Fails when the options are out of range or the scene emits nothing.
  static Expected<StochasticRadiosity> build(const Scene& scene, const StochasticOptions& options);

  // One iteration (options.shooters random operators).
  StochasticIteration step();
  // Iterates until the iteration cap or the time limit; `after` after every iteration, `stop`
  // before each (true: return now).
  StochasticStats solve(const std::function<void(const StochasticIteration&)>& after = {},
                        const std::function<bool()>& stop = {});

  // Sec. 3.1's selection on the current iterate from one uniform number u in [0, 1): the
  // element, and its probability P_j; the iterate must hold light (power() > 0). (Public for
  // the tests.)
  uint32_t select(double u, double* probability) const;
  // Phi = sum lum(B_j) A_j of the current iterate (W).
  double power() const { return total_; }

  int iterations() const { return iterations_; }
  int burnIn() const { return burn_in_; }
  // Iterates in the average.
  int averaged() const { return std::max(iterations_ - burn_in_, 0); }
  // The first shots made in build() (the lights' counting as one), and their seconds.
  int firstShots() const { return first_shots_; }
  double firstShotSeconds() const { return first_seconds_; }
  // The estimate B_p - dB + B~ (W m^-2) per element (B_p - dB + the iterate during the burn-in),
  // and the relative RMS error estimate.
  glm::dvec3 radiosity(size_t e) const;
  std::vector<glm::dvec3> radiosity() const;
  double errorEstimate() const;
  // The state, and restoring one taken from a solver on the same scene and options (checked by
  // element count and values; the caller checks the scene).
  StochasticState state() const;
  Status setState(StochasticState state);
  // The local operator's pairs of receiver r: local()[localBegin(r) .. localBegin(r + 1)).
  uint32_t localBegin(size_t r) const { return local_first_[r]; }
  const std::vector<StochasticLocalPair>& local() const { return local_; }
  // The current iterate B_m, E', and B_p - dB from the first shots (zero without them).
  const glm::dvec3& iterate(size_t e) const { return b_[e]; }
  const glm::dvec3& source(size_t e) const { return source_[e]; }
  const glm::dvec3& shot(size_t e) const { return shot_[e]; }

  size_t elementCount() const { return surface_.elementCount(); }
  const RadiositySurface& surface() const { return surface_; }
  const ChartAtlas& atlas() const { return surface_.atlas; }
  const FlatTriangles& triangles() const { return surface_.flat; }
  const StochasticOptions& options() const { return options_; }

  // Outgoing radiance B~ / pi per atlas texel, gaps filled (RadiositySurface::radianceImage).
  Image radianceImage() const;

 private:
  StochasticOptions options_;
  RadiositySurface surface_;
  std::vector<glm::dvec3> source_;  // E' per element
  std::vector<glm::dvec3> shot_;    // B_p - dB per element (the first shots)
  double source_power_ = 0.0;       // Phi of E'
  int first_shots_ = 0;
  double first_seconds_ = 0.0;
  std::vector<glm::dvec3> b_;       // the current iterate
  std::vector<glm::dvec3> sum_[2];  // iterates summed by the parity of their number
  int iterations_ = 0;
  bool dark_ = false;  // no light reaches a surface: every iteration leaves the solution black
  int burn_in_ = 0;
  // Per hierarchy level, per cluster: sum of lum(B) A over its elements (the mipmap of sec. 3.1).
  std::vector<std::vector<double>> level_sums_;
  std::vector<double> root_cdf_;  // running sum over the charts' roots
  double total_ = 0.0;
  // Per element, its pieces (for the near pairs' exact form factor).
  std::vector<uint32_t> piece_first_;
  std::vector<std::pair<std::array<glm::dvec3, 8>, int>> pieces_;
  // The local operator, per receiver (CSR).
  std::vector<uint32_t> local_first_;
  std::vector<StochasticLocalPair> local_;

  // E' (and B_p - dB) with first_shots = 0, and with first shots.
  Status buildSource(const Scene& scene);
  Status shootFirst(const Scene& scene);
  // The local operator's pairs (needs the pieces).
  void buildLocal();
  // Whether (r, j) is a pair at all (r faces j, j faces r, not texels of one planar chart), and
  // its distance squared; pairs with d2 < kStochasticLocal^2 A_j are the local operator's.
  bool facing(size_t r, uint32_t j, double* d2) const;
  void buildSums();
  // Adds (1 / count) T*_j b_prev into `out` for shooter j chosen with probability p.
  uint64_t shoot(uint32_t j, double p, double weight, const std::vector<glm::dvec3>& from,
                 std::vector<glm::dvec3>& out) const;
};

}  // namespace penumbra
