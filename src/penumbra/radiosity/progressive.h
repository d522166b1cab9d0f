// Progressive refinement radiosity on triangle meshes with lightmaps (Wallner, sec. 2-3), the CPU
// version: every triangle's radiosity and residual (unshot) radiosity live in per-triangle
// textures packed in one atlas (geometry/lightmap_atlas.h), and each occupied texel is an element.
//
//  - Elements: the `kInside` texels of the atlas (the paper's alpha = 1 texels). An element is
//    the part of its triangle that its texel square covers (exact coverage, the CPU variant of
//    the paper's area / occlusion-query count of sec. 3: the clipped squares tile the triangle);
//    its point is that part's centroid. Not the texel centre: along a chart's edges the centres
//    lie on the triangle's edges, where a point sees the neighbouring faces of a closed room
//    edge-on; with centres and equal areas the furnace loses a third of every shot. Elements are
//    one-sided like the matrix method's (radiosity/elements.h): they emit and reflect from the
//    counter-clockwise front face, with E = pi * emitted radiance and the material's reflectance.
//  - Units: B and dB (unshot radiosity) in W m^-2 per RGB channel; the power of an element is
//    B * area (W). Everything is kept in double so that the energy bookkeeping is exact.
//  - Shooter selection (sec. 3): the triangle with the highest residual power, the sum over its
//    occupied texels of the luminance of dB (I = 0.3 R + 0.59 G + 0.11 B, the paper's weights)
//    times the texel's area. This is the CPU twin of the paper's mipmap reduction that averages
//    only occupied texels (then multiplies by the triangle's area), computed exactly in one pass
//    and weighted by each texel's coverage rather than by 2 x 2 ping-pong passes.
//  - Shooting (eq. 1-2): the shooter's unshot radiosity reaches every receiver element r in
//    front of the shooter's plane that faces it, r gains  dB_r += rho_r dB_s F_rs  and B_r += the
//    same (the progressive form of eq. 1); then dB_s = 0. Visibility: one Ray Engine shadow ray
//    per (receiver, shooter point) pair, the rays of a block of receivers sorted by point so that
//    they travel as packets. The shooter points (substructuring, sec. 3):
//     - flat (shooter_top_points = 0, the paper's scheme and the GPU path's): every element, or
//       every block of 2^level x 2^level atlas texels (the paper's coarser mip level), is a
//       point; eq. 2's disc
//         F_rs = A_s cos(phi_s) cos(phi_r) / (pi d^2 + A_s)                  (eq. 2, m = 1)
//       except for pairs nearer than kProgressiveNear point sizes, where a disc is a poor
//       stand-in for a neighbour seen edge-on: each member element then counts with Lambert's
//       exact point-to-polygon form factor to its own polygon;
//     - hierarchical (the default): the shooter's texels grouped into 2 x 2, 4 x 4, ... blocks up
//       to the first level with at most shooter_top_points blocks; a receiver takes a block as
//       one point unless nearer than kProgressiveNear block sizes (then its sub-blocks, down to
//       elements), and blocks coarser still (up to the whole shooter) when farther than 20 of
//       their sizes; eq. 2's disc beyond 8 sizes, Lambert's form factor to the block's polygon
//       (its texels' part of the chart) with the block's mean dB nearer. The furnace's worst
//       element is 0.06% off this way, 0.81% with the flat scheme (progressive_test.cpp).
//  - Energy bookkeeping (W, per channel): the power shot, P = sum_s dB_s A_s, either arrives at
//    receivers, Q = sum_r (sum_s dB_s F_rs) A_r, of which rho Q is reflected (joins the unshot
//    power) and (1 - rho) Q is absorbed, or does not arrive: P - Q is counted as escaped. In an
//    open scene (the Cornell box) that is the light leaving through the opening; in a closed one
//    it is the form factors' departure from reciprocity and eq. 3 (negative when they
//    overestimate). So, after every iteration,
//      emitted = absorbed + unshot + escaped
//    holds exactly up to rounding.
//  - Ambient term (eq. 4-6, Cohen et al. 1988): A = R sum_j dB_j A_j / sum_k A_k with the
//    interreflection factor R = 1 / (1 - sum_k rho_k A_k / sum_k A_k); displayed radiosity
//    B + rho A during early iterations. It is exposed for display only, never added to B.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/core/timer.h"
#include "penumbra/geometry/lightmap_atlas.h"
#include "penumbra/raytrace/ray_engine.h"
#include "penumbra/scene/scene.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

namespace penumbra {

// Pairs closer than this many shooter element sizes (sqrt of the point's area) use Lambert's
// exact point-to-polygon form factor instead of eq. 2's disc (and, in the hierarchical mode,
// blocks that near are refined).
inline constexpr double kProgressiveNear = 3.0;

struct ProgressiveOptions {
  AtlasOptions atlas;         // the texel density (or atlas resolution) sets the element size
  int max_iterations = 1000;  // shooters (one iteration = one shooter triangle)
  double convergence = 1e-3;  // stop when unshot power / emitted power (luminance) <= this
  // Substructuring (sec. 3). shooter_top_points > 0 (the default): hierarchical, each shooter's
  // elements grouped into blocks of 2x2, 4x4, ... texels up to the first level with at most this
  // many blocks; a receiver takes a block as one point when it is farther than 3 block sizes,
  // else its sub-blocks, down to the elements. 0: the paper's flat scheme, every element of the
  // shooter's mip level `shooter_level` (blocks of 2^level x 2^level texels) shoots to every
  // receiver (what the GPU path does).
  int shooter_top_points = 16;
  int shooter_level = 0;
  bool visibility = true;  // false: no shadow rays (every pair in front is unoccluded)
  // The form factors' cosines take shading normals interpolated across the triangles (the
  // mesh's own vertex normals, or generated ones: geometry/shading_normals.h), as the paper
  // interpolates normals, so tessellated curved surfaces shade smoothly; false: each
  // triangle's own normal. Flat surfaces are the same either way. Culling and shadow rays use
  // the triangles' own normals in both cases.
  bool shading_normals = true;
};

// Power totals in W per RGB channel.
struct EnergyBalance {
  glm::dvec3 emitted{0.0};   // sum E A at the start
  glm::dvec3 absorbed{0.0};  // (1 - rho) of the power that arrived at receivers
  glm::dvec3 unshot{0.0};    // running sum: emitted - shot + reflected
  glm::dvec3 escaped{0.0};   // shot but not arrived (see the file comment)
};

struct ProgressiveIteration {
  int iteration = 0;             // 1 for the first shooter
  uint32_t shooter = 0;          // the shooter triangle (flattenScene order)
  uint32_t shooter_points = 0;   // top-level elements or blocks that shot
  double shot_power = 0.0;       // luminance of the power shot (W)
  double unshot_fraction = 0.0;  // unshot / emitted power (luminance) after the iteration
  uint64_t rays = 0;
  double seconds = 0.0;
};

// The solver's state between iterations: what a checkpoint holds and what another device hands
// back. Element order is ProgressiveRadiosity's.
struct ProgressiveState {
  std::vector<glm::dvec3> radiosity;  // B per element (W m^-2)
  std::vector<glm::dvec3> residual;   // dB per element
  EnergyBalance balance;
  int iterations = 0;
};

struct ProgressiveStats {
  int iterations = 0;        // in this call to solve()
  int total_iterations = 0;  // including those before it (a resumed checkpoint's)
  double unshot_fraction = 0.0;
  bool converged = false;    // unshot_fraction <= options.convergence (or nothing left to shoot)
  bool interrupted = false;  // `stop` asked to stop before convergence or the cap
  uint64_t rays = 0;
  double seconds = 0.0;
};

// Luminance weights of Wallner sec. 3 (I = 0.3 R + 0.59 G + 0.11 B).
inline double residualLuminance(const glm::dvec3& c) {
  return 0.3 * c.x + 0.59 * c.y + 0.11 * c.z;
}

// The iteration loop of solve() on every device: iterates until the unshot fraction reaches
// options.convergence, the solver's iteration count reaches options.max_iterations (counted
// over its whole life) or `stop` says so. `step()` gives Expected<ProgressiveIteration>
// (iteration 0: nothing left to shoot), `nothing_left()` Expected<bool>, `iterations()` the
// solver's count.
template <typename Step, typename NothingLeft, typename Iterations>
Expected<ProgressiveStats> solveProgressively(
    const ProgressiveOptions& options, double unshot_fraction, Step&& step,
    NothingLeft&& nothing_left, Iterations&& iterations,
    const std::function<void(const ProgressiveIteration&)>& after_iteration,
    const std::function<bool()>& stop) {
  const Timer timer;
  ProgressiveStats st;
  st.unshot_fraction = unshot_fraction;
  while (st.unshot_fraction > options.convergence && iterations() < options.max_iterations) {
    if (stop && stop()) {
      st.interrupted = true;
      break;
    }
    Expected<ProgressiveIteration> it = step();
    if (!it) return it.error();
    if (it->iteration == 0) break;  // nothing left to shoot
    ++st.iterations;
    st.rays += it->rays;
    st.unshot_fraction = it->unshot_fraction;
    if (after_iteration) after_iteration(*it);
  }
  st.converged = st.unshot_fraction <= options.convergence;
  if (!st.converged) {
    Expected<bool> none = nothing_left();
    if (!none) return none.error();
    st.converged = *none;
  }
  st.total_iterations = iterations();
  if (st.converged) st.interrupted = false;
  st.seconds = timer.seconds();
  return st;
}

class ProgressiveRadiosity {
 public:
  static constexpr uint32_t kNoShooter = std::numeric_limits<uint32_t>::max();

  // Builds the atlas over the scene's flattened triangles (the scene must have passed
  // validateScene) and sets B = dB = E. Fails when the atlas cannot be built, the options are
  // out of range, or the scene emits nothing.
  static Expected<ProgressiveRadiosity> build(const Scene& scene,
                                              const ProgressiveOptions& options);

  // The triangle with the highest residual power (luminance), kNoShooter when none is left.
  uint32_t selectShooter() const;
  // Residual power of triangle t: sum of luminance(dB) * area over its elements (W).
  double residualPower(uint32_t triangle) const;
  // One iteration with triangle `shooter` as the shooter.
  ProgressiveIteration shoot(uint32_t shooter);
  // Selects the shooter and shoots; returns iteration 0 (nothing done) when nothing is left.
  ProgressiveIteration step();
  // Iterates until the convergence fraction or the iteration cap (counted over the solver's
  // whole life, so a resumed checkpoint's iterations count); `after_iteration` is called after
  // every iteration, `stop` before each (true: return now, between two iterations).
  ProgressiveStats solve(
      const std::function<void(const ProgressiveIteration&)>& after_iteration = {},
      const std::function<bool()>& stop = {});

  // The state, and restoring one taken from a solver on the same scene and options (checked by
  // element count; the caller checks that the scene is the same).
  ProgressiveState state() const;
  Status setState(ProgressiveState state);
  int iterations() const { return iterations_; }
  const ProgressiveOptions& options() const { return options_; }
  // The flat scheme's mip level (ProgressiveOptions::shooter_level), in [0, 16].
  Status setShooterLevel(int level);
  // Energy totals as booked, and the unshot power recomputed from the elements' dB (W).
  const EnergyBalance& balance() const { return balance_; }
  glm::dvec3 unshotPower() const;
  double unshotFraction() const;  // unshot / emitted power, luminance
  // Eq. 4-6: the ambient radiosity (W m^-2) for display; B_display = B + rho * ambient().
  glm::dvec3 ambient() const;
  glm::dvec3 displayRadiosity(size_t element) const;

  // Elements (kInside texels), grouped by triangle: elements of triangle t are
  // [triangleFirst(t), triangleFirst(t + 1)).
  size_t elementCount() const { return texel_.size(); }
  size_t triangleCount() const { return tri_first_.size() - 1; }
  uint32_t triangleFirst(uint32_t t) const { return tri_first_[t]; }
  uint32_t elementTriangle(size_t e) const { return tri_of_[e]; }
  uint32_t elementTexel(size_t e) const { return texel_[e]; }  // atlas texel index
  double elementArea(size_t e) const { return area_[e]; }
  const glm::dvec3& elementPosition(size_t e) const { return position_[e]; }
  glm::ivec2 elementLattice(size_t e) const { return lattice_[e]; }  // (i, j) in its chart
  // The element's polygon in world space (its texel square clipped to its triangle): the count.
  int elementPolygon(uint32_t e, std::array<glm::dvec3, 8>& out) const;
  // The flat substructuring's shooter points of triangle t (sec. 3): its elements of non-zero
  // area grouped by blocks of 2^level x 2^level atlas texels, in the order shoot() takes them.
  std::vector<std::vector<uint32_t>> shooterBlocks(uint32_t t, int level) const;
  const glm::dvec3& radiosity(size_t e) const { return b_[e]; }
  const glm::dvec3& residual(size_t e) const { return db_[e]; }
  const glm::dvec3& reflectance(size_t e) const { return rho_[e]; }
  const glm::dvec3& emission(size_t e) const { return e_[e]; }
  double triangleArea(uint32_t t) const { return tri_area_[t]; }
  const LightmapAtlas& atlas() const { return atlas_; }
  const FlatTriangles& triangles() const { return flat_; }

  // Outgoing radiance B / pi (W m^-2 sr^-1) per atlas texel, the size of the atlas: kInside
  // texels hold their element's value (plus rho * ambient when `with_ambient`), kBorder and
  // kDilated texels the mean of adjacent filled texels of the same triangle (constant extension
  // for bilinear lookups), kEmpty texels zero.
  Image radianceImage(bool with_ambient = false) const;
  // Area-weighted mean B per triangle (W m^-2), flattenScene order.
  std::vector<glm::dvec3> triangleRadiosity() const;

 private:
  ProgressiveOptions options_;
  LightmapAtlas atlas_;
  FlatTriangles flat_;
  RayEngine engine_;
  double lift_ = 0.0;  // shadow-ray end points are lifted off their surfaces by this (m)
  // Per triangle.
  std::vector<uint32_t> tri_first_;  // size triangles + 1
  std::vector<double> tri_area_;
  std::vector<glm::dvec3> tri_normal_;  // unit front normal (zero for degenerate triangles)
  // Per element.
  std::vector<uint32_t> texel_, tri_of_;
  std::vector<glm::ivec2> lattice_;  // per element: its texel's lattice point (i, j) in the chart
  // The element polygon (elementPolygon) for the lattice points [lo, hi] of triangle t's chart
  // together (a block of texels).
  int blockPolygon(uint32_t t, glm::ivec2 lo, glm::ivec2 hi, std::array<glm::dvec3, 8>& out) const;
  std::vector<double> area_;
  std::vector<glm::dvec3> position_, normal_, rho_, e_, b_, db_;  // normal_: shading normal
  std::vector<double> tri_power_;     // residualPower per triangle, for selectShooter
  std::vector<glm::dvec3> incident_;  // per element, an iteration's gathered irradiance
  void refreshTrianglePowers();
  EnergyBalance balance_;
  glm::dvec3 ambient_factor_{1.0};  // R of eq. 6, per channel
  double total_area_ = 0.0;
  int iterations_ = 0;
};

}  // namespace penumbra
