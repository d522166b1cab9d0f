// Progressive refinement radiosity with lightmaps (Wallner, sec. 2-3), the CPU version, on the
// chart atlas and its multiresolution hierarchy (geometry/chart_atlas.h, surface_hierarchy.h):
// the radiosity and the residual (unshot) radiosity live in the atlas, and each occupied texel
// is an element.
//
//  - Elements: the atlas's kInside texels, with their exact coverage (the pieces of the chart's
//    faces inside the texel square, mapped to the surface): area, centroid (on the surface),
//    normal. Texels sit
//    on faces, so two-sided surfaces (Material::two_sided) have elements on each side, each
//    emitting (front faces only, E = pi * emitted radiance) and reflecting on its own side.
//  - Units: B and dB in W m^-2 per RGB channel; the power of an element is B * area (W), kept
//    in double so that the energy books are exact.
//  - Shooters (sec. 3, the mipmap selection): clusters of the hierarchy, each chart's root (or,
//    for a chart of more than shooter_elements elements, the largest clusters under it that
//    are not), so that a 69k-triangle scan shoots as a few hundred charts rather than 69k
//    triangles. The one with the highest residual power (the luminance of dB, I = 0.3 R +
//    0.59 G + 0.11 B, times area, over its elements) shoots.
//  - Lights: point, spot and directional lights shoot first, in one iteration (iteration 1,
//    shooter kLights): every element facing a light receives its irradiance, I cos / d^2 for
//    a point or spot (with the glTF cone fall-off), E cos for a directional light, with a Ray
//    Engine shadow ray; their power is booked as emitted (4 pi I for a point, the integral of
//    the cone for a spot). A directional light (the sun) has no power of its own: the books take
//    what it delivers to the surfaces that take part. The sky or the uniform environment shoots
//    in the same iteration, as direct irradiance at every element (radiosity/outside_light.h),
//    and is booked the same way.
//  - Shooting (eq. 1-2): the shooter's unshot radiosity reaches every receiver element r in
//    front of it that faces it: dB_r += rho_r dB_s F_rs, B_r += the same; then dB_s = 0.
//    Visibility: one Ray Engine shadow ray per (receiver, shooter point) pair, the rays of a
//    block of receivers sorted by point so that they travel as packets. A receiver whose rays
//    disagree (some points hidden, some not: it lies in a penumbra, or behind a lattice) traces
//    penumbra_rays rays per pair instead and takes the visible fraction: binary visibility to
//    16 points leaves 1 / sqrt(16) of noise where a cut-out lattice hides 40% of a panel (12%
//    RMS on the textured room's floor). The rays leave points of the pair's point drawn by its
//    residual power (an element by its share along the Morton order, stratified, then a point
//    of its pieces uniform by area), so a cluster half under a box is sampled on its lit half
//    as its centroid is. Shot s takes ceil(penumbra_rays P_s / P_max) rays, P_max the brightest
//    emitter's power: the noise a shot leaves scales with its power over the square root of
//    its rays, and rays in proportion to power minimise the summed variance for a given count.
//    The shooter points
//    (substructuring, sec. 3) are the shooter's clusters in the hierarchy, each at the centroid
//    of its residual power (luminance(dB) times area; a cluster half under a box shoots from its
//    lit half, not from a point under the box that its shadow rays would find hidden):
//     - flat (shooter_top_points = 0, the paper's scheme and the GPU path's): every cluster of
//       level `shooter_level` is a point; eq. 2's disc
//         F_rs = A_s cos(phi_s) cos(phi_r) / (pi d^2 + A_s)                  (eq. 2, m = 1)
//       for pairs kProgressiveFar point sizes apart or more, Lambert's form factor to the
//       point's pieces with its mean dB nearer, and for pairs nearer than kProgressiveNear
//       sizes each member element's own Lambert form factor to its own pieces;
//     - hierarchical (the default): the first level under the shooter with at most
//       shooter_top_points clusters is the top; a receiver takes a cluster as one point unless
//       nearer than kProgressiveNear of its sizes (then its children, down to elements), and
//       clusters above the top (up to the shooter) when farther than 20 of their sizes;
//       eq. 2's disc beyond 8 sizes, Lambert's form factor to the cluster's pieces (its texels'
//       part of the chart) with the cluster's mean dB nearer.
//  - Closed shots: a shot's form factors are sums of approximations, so what arrives differs
//    from what was shot by their error even in a closed room. Each shot first sends
//    probe_rays rays (cosine-distributed from points spread over the shooter by area, or from
//    the lights); if every one of them hits a face that has elements, the shot is closed and
//    the gathered irradiance is scaled so that the power arriving equals the power shot
//    (Sum_r F_rs A_r = A_s, the form factors' sum rule). Otherwise (an opening, or black backs
//    of one-sided surfaces) the shot keeps its form factors as computed.
//  - Energy bookkeeping (W, per channel): the power shot either arrives at receivers, of which
//    rho is reflected (joins the unshot power) and 1 - rho absorbed, or does not arrive and is
//    counted as escaped (through openings, or onto black back faces). After every iteration
//      emitted = absorbed + unshot + escaped
//    holds up to rounding; in a closed scene of two-sided surfaces escaped stays 0.
//  - Receivers and adaptive subdivision (sec. 4, radiosity/progressive_receivers.h): receivers
//    are clusters of the hierarchy, each gathering at one point, the elements under them taking
//    interpolated values; by default every element receives on its own (receiver level 0). With
//    `adaptive`, receivers start as clusters of a coarser level and are split at shadow
//    boundaries before each shooter (and the lights) shoots for the first time.
//  - Ambient term (eq. 4-6, Cohen et al. 1988): A = R sum_j dB_j A_j / sum_k A_k with
//    R = 1 / (1 - sum_k rho_k A_k / sum_k A_k); displayed radiosity B + rho A during early
//    iterations, never added to B.
#pragma once

#include "penumbra/cluster/communicator.h"
#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/core/timer.h"
#include "penumbra/geometry/chart_atlas.h"
#include "penumbra/geometry/surface_hierarchy.h"
#include "penumbra/radiosity/outside_light.h"
#include "penumbra/radiosity/progressive_receivers.h"
#include "penumbra/radiosity/radiosity_surface.h"
#include "penumbra/raytrace/ray_engine.h"
#include "penumbra/scene/scene.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <vector>

namespace penumbra {

// Pairs closer than this many shooter element sizes (sqrt of the point's area) use Lambert's
// exact point-to-polygon form factor instead of eq. 2's disc (and, in the hierarchical mode,
// clusters that near are refined).
inline constexpr double kProgressiveNear = 3.0;
// Eq. 2's disc serves pairs at least this many point sizes apart; nearer ones (from
// kProgressiveNear on) take Lambert's exact form factor to the point's pieces (its faces clipped
// to its texels) with its mean dB. The disc's error falls with the square of size / distance.
inline constexpr double kProgressiveFar = 8.0;

// Lightmap texels when the caller names no density (radiosity/radiosity_surface.h).
inline constexpr uint32_t kProgressiveDefaultElements = kDefaultLightmapElements;

// texelDensityFor (radiosity/radiosity_surface.h).
double progressiveTexelDensity(const Scene& scene, uint32_t elements);

struct ProgressiveOptions {
  ChartAtlasOptions atlas;    // the texel density (or atlas resolution) sets the element size
  int max_iterations = 1000;  // shots (the lights' shot counts as one)
  double convergence = 1e-3;  // stop when unshot power / emitted power (luminance) <= this
  // Substructuring (sec. 3). shooter_top_points > 0 (the default): hierarchical, from the
  // first level under the shooter with at most this many clusters. 0: the paper's flat scheme,
  // every cluster of level `shooter_level` of the shooter shoots to every receiver (the GPU
  // path's).
  int shooter_top_points = 16;
  int shooter_level = 0;
  // The flat scheme: a shooter with fewer than this many clusters at `shooter_level` shoots
  // from the coarsest finer level that has them (or from its elements), so that a small emitter
  // does not cast its whole light, and its shadows, from one point (flatLevel).
  int shooter_min_points = 16;
  // Shooters are chart roots, or the largest clusters under a root with at most this many
  // elements.
  uint32_t shooter_elements = 1u << 16;
  bool visibility = true;  // false: no shadow rays (every pair in front is unoccluded)
  // Penumbrae (see the file comment): a receiver whose shadow rays to the shooter's points
  // disagree traces this many rays to each point, from points of the point's residual power,
  // and takes the visible fraction; shots weaker than the brightest emitter take
  // proportionally fewer. 1: one ray per pair (the paper's).
  int penumbra_rays = 16;
  // The form factors' cosines take shading normals interpolated across the triangles (the
  // mesh's own vertex normals, or generated ones: geometry/shading_normals.h), as the paper
  // interpolates normals, so tessellated curved surfaces shade smoothly; false: the faces' own
  // normals. Culling and shadow rays use the faces' own normals in both cases.
  bool shading_normals = true;
  // Rays per shot that decide whether it is closed (see the file comment); 0: never normalise.
  int probe_rays = 1024;
  // Receivers (radiosity/progressive_receivers.h): clusters of this level of the hierarchy
  // (2^l x 2^l texels of a chart) gather, each at one point, and the elements under them take
  // interpolated values. -1: 0 (every element receives), or kAdaptiveReceiverLevel when
  // `adaptive`.
  int receiver_level = -1;
  // Adaptive subdivision at shadow boundaries (sec. 4): receivers are split where a shooter's
  // shadow boundaries cross them, before it first shoots.
  bool adaptive = false;
  SubdivisionOptions subdivision;
};

// Power totals in W per RGB channel.
struct EnergyBalance {
  glm::dvec3 emitted{0.0};   // sum E A at the start
  glm::dvec3 absorbed{0.0};  // (1 - rho) of the power that arrived at receivers
  glm::dvec3 unshot{0.0};    // running sum: emitted - shot + reflected
  glm::dvec3 escaped{0.0};   // shot but not arrived (see the file comment)
};

struct ProgressiveIteration {
  int iteration = 0;             // 1 for the first shot
  uint32_t shooter = 0;          // the shooter (ProgressiveRadiosity::shooter*), or kLights
  uint32_t shooter_points = 0;   // top-level points that shot
  double shot_power = 0.0;       // luminance of the power shot (W)
  double unshot_fraction = 0.0;  // unshot / emitted power (luminance) after the iteration
  bool closed = false;           // every probe ray found a face with elements: normalised
  uint64_t rays = 0;             // shadow, probe and subdivision rays
  double seconds = 0.0;
  // Adaptive subdivision before the shot (sec. 4): receivers split, and the time it took (part
  // of `seconds`, the bracketed times of the paper's Table 1).
  uint32_t refined = 0;
  double subdivision_seconds = 0.0;
};

// The solver's state between iterations: what a checkpoint holds and what another device hands
// back. Element order is ProgressiveRadiosity's.
struct ProgressiveState {
  std::vector<glm::dvec3> radiosity;  // B per element (W m^-2)
  std::vector<glm::dvec3> residual;   // dB per element
  EnergyBalance balance;
  int iterations = 0;
  bool lights_shot = true;  // the point, spot and directional lights have shot
  // Per element, the level of the receiver over it (ProgressiveReceivers::elementLevels), and
  // per shooter and then the lights whether subdivision has run for it (adaptive only); empty:
  // the solver's own.
  std::vector<uint8_t> receiver_levels;
  std::vector<uint8_t> subdivided;
};

struct ProgressiveStats {
  int iterations = 0;        // in this call to solve()
  int total_iterations = 0;  // including those before it (a resumed checkpoint's)
  double unshot_fraction = 0.0;
  bool converged = false;    // unshot_fraction <= options.convergence (or nothing left to shoot)
  bool interrupted = false;  // `stop` asked to stop before convergence or the cap
  uint64_t rays = 0;
  double seconds = 0.0;
  uint32_t refined = 0;              // receivers split by adaptive subdivision
  double subdivision_seconds = 0.0;  // of `seconds`
};

// Luminance weights of Wallner sec. 3 (I = 0.3 R + 0.59 G + 0.11 B).
inline double residualLuminance(const glm::dvec3& c) {
  return 0.3 * c.x + 0.59 * c.y + 0.11 * c.z;
}

// Adaptive subdivision's contrast test (radiosity/progressive_receivers.h), on every device:
// a whole shooter's unoccluded irradiance at a sample (point p, face normal n) as one disc of
// eq. 2 (luminance, W m^-2), and the share E_s / (E_before + E_s) the sample counts with,
// E_before = (B - E) / rho from its radiosity, emission and reflectance (luminances).
double shooterDiscIrradiance(const glm::dvec3& residual, double area, const glm::dvec3& position,
                             const glm::dvec3& normal, const glm::dvec3& p, const glm::dvec3& n);
double subdivisionShare(double shooter_irradiance, const glm::dvec3& radiosity,
                        const glm::dvec3& emission, const glm::dvec3& reflectance);

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
    st.refined += it->refined;
    st.subdivision_seconds += it->subdivision_seconds;
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
  static constexpr uint32_t kLights = std::numeric_limits<uint32_t>::max() - 1;

  // Builds the atlas over the scene's faces (the scene must have passed validateScene) and sets
  // B = dB = E. Fails when the atlas cannot be built, the options are out of range, or the
  // scene has neither emissive surfaces nor lights.
  static Expected<ProgressiveRadiosity> build(const Scene& scene,
                                              const ProgressiveOptions& options);
  // The same over a surface already built for `scene` with options.atlas and
  // options.shading_normals (the options are the caller's to have checked).
  static Expected<ProgressiveRadiosity> build(RadiositySurface surface, const Scene& scene,
                                              const ProgressiveOptions& options);
  // Hands the surface on (to a solver that continues from this one's state); this solver is
  // left unusable.
  RadiositySurface takeSurface() && { return std::move(surface_); }

  // The next shot: kLights while the lights have not shot, else the shooter with the highest
  // residual power, kNoShooter when nothing is left.
  uint32_t selectShooter() const;
  // Residual power of shooter s: sum of luminance(dB) * area over its elements (W).
  double residualPower(uint32_t shooter) const;
  // One iteration with `shooter` (a shooter index or kLights) as the shooter.
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
  // The flat scheme's level (ProgressiveOptions::shooter_level), in [0, 16].
  Status setShooterLevel(int level);
  // The level shooter s shoots from in the flat scheme: shooter_level (at most the shooter's
  // own), made finer while it has fewer than shooter_min_points clusters there.
  int flatLevel(uint32_t s) const;
  // Energy totals as booked, and the unshot power recomputed from the elements' dB (W).
  const EnergyBalance& balance() const { return balance_; }
  glm::dvec3 unshotPower() const;
  double unshotFraction() const;  // unshot / emitted power, luminance
  bool lightsShot() const { return lights_shot_; }
  // Whether a shot from shooter s (or kLights) is closed: every one of probe_rays rays,
  // cosine-distributed from points spread over the shooter by area (or leaving the lights as
  // they emit), hits a face that has elements. Deterministic; probed once and remembered (the
  // rays traced, if any, are added to *traced).
  bool shotClosed(uint32_t shooter, uint64_t* traced = nullptr) const;
  // Eq. 4-6: the ambient radiosity (W m^-2) for display; B_display = B + rho * ambient().
  glm::dvec3 ambient() const;
  glm::dvec3 displayRadiosity(size_t element) const;

  // Elements: the atlas's elements (grouped by chart, Morton order within a chart).
  size_t elementCount() const { return surface_.elementCount(); }
  uint32_t elementChart(size_t e) const { return surface_.atlas.element_chart[e]; }
  uint32_t elementTexel(size_t e) const { return surface_.atlas.element_texel[e]; }
  double elementArea(size_t e) const { return surface_.atlas.element_area[e]; }
  const glm::dvec3& elementPosition(size_t e) const { return surface_.atlas.element_position[e]; }
  const glm::dvec3& elementNormal(size_t e) const { return surface_.atlas.element_normal[e]; }
  // The element's pieces in world space (one convex polygon per face it overlaps).
  void elementPieces(size_t e, std::vector<std::array<glm::dvec3, 8>>& polygons,
                     std::vector<int>& counts) const;
  // Shooters: clusters of the hierarchy; shooter s holds elements
  // [shooterBegin(s), shooterEnd(s)).
  size_t shooterCount() const { return shooters_.size(); }
  ClusterRef shooterCluster(uint32_t s) const { return shooters_[s]; }
  uint32_t shooterBegin(uint32_t s) const { return surface_.hierarchy.elementBegin(shooters_[s]); }
  uint32_t shooterEnd(uint32_t s) const { return surface_.hierarchy.elementEnd(shooters_[s]); }
  // The flat substructuring's points of shooter s (sec. 3): its clusters at `level` (at most
  // the shooter's own level); cluster c holds the elements [hierarchy().elementBegin(c),
  // hierarchy().elementEnd(c)).
  std::vector<ClusterRef> shooterBlocks(uint32_t s, int level) const;
  // A cluster's pieces in world space: its elements' faces clipped to its texels (one convex
  // polygon per face), what Lambert's form factor to the cluster integrates over.
  void clusterPieces(ClusterRef c, std::vector<std::array<glm::dvec3, 8>>& polygons,
                     std::vector<int>& counts) const;
  const glm::dvec3& radiosity(size_t e) const { return b_[e]; }
  const glm::dvec3& residual(size_t e) const { return db_[e]; }
  const glm::dvec3& reflectance(size_t e) const { return surface_.reflectance[e]; }
  const glm::dvec3& emission(size_t e) const { return surface_.emission[e]; }
  const glm::dvec3& shadingNormal(size_t e) const { return surface_.shading_normal[e]; }
  const RadiositySurface& surface() const { return surface_; }
  const ChartAtlas& atlas() const { return surface_.atlas; }
  const SurfaceHierarchy& hierarchy() const { return surface_.hierarchy; }
  const FlatTriangles& triangles() const { return surface_.flat; }
  const std::vector<Light>& lights() const { return lights_; }
  double totalArea() const { return surface_.total_area; }
  // The receivers (sec. 4) and the level they started from.
  const ProgressiveReceivers& receivers() const { return receivers_; }
  int receiverLevel() const { return receiver_level_; }

  // The ranks that share the shots (docs/scaling.md; null: one process). Each rank gathers at a
  // share of the receivers and they exchange the irradiance, so every rank holds the whole
  // solution, and each shot, the shooter chosen next, the balance and the checkpoint are one
  // process's bit for bit. shoot(), step() and solve() are then collective.
  void setCommunicator(Communicator* comm) { comm_ = comm && comm->distributed() ? comm : nullptr; }
  Communicator* communicator() const { return comm_; }

  // Outgoing radiance B / pi (W m^-2 sr^-1) per atlas texel, the size of the atlas: kInside
  // texels hold their element's value (plus rho * ambient when `with_ambient`), kBorder and
  // kDilated texels the mean of adjacent filled texels of the same chart (in rounds), kEmpty
  // texels zero.
  Image radianceImage(bool with_ambient = false) const;

 private:
  ProgressiveOptions options_;
  RadiositySurface surface_;
  std::vector<Light> lights_;
  bool lights_shot_ = true;
  glm::dvec3 light_power_{0.0};
  // The sky (scene/sky.h) or the environment, shot with the lights: their irradiance at every
  // element, through the openings and by cosine rays that leave the scene
  // (radiosity/outside_light.h); what it brings is booked as emitted.
  std::optional<OutsideLight> outside_;
  std::vector<ClusterRef> shooters_;
  ProgressiveReceivers receivers_;
  int receiver_level_ = 0;
  std::vector<uint8_t> subdivided_;  // per shooter, then the lights
  // Per element.
  std::vector<glm::dvec3> b_, db_;
  std::vector<double> shooter_power_;  // residualPower per shooter, for selectShooter
  double emitter_power_ = 0.0;         // the brightest shooter's emitted power (luminance, W)
  std::vector<glm::dvec3> incident_;   // per element, an iteration's gathered irradiance
  EnergyBalance balance_;
  glm::dvec3 ambient_factor_{1.0};  // R of eq. 6, per channel
  int iterations_ = 0;
  Communicator* comm_ = nullptr;

  mutable std::vector<int8_t> closed_;  // per shooter, then the lights: -1 not probed yet
  ProgressiveIteration shootLights();
  // Sec. 4 before a first shot: `sample(e, counted, visible)` gives element e's visibility
  // samples (called for the elements under receivers coarser than the finest level, in
  // parallel); splits the receivers and records the split count, the time and the rays in *it.
  template <typename Sample>
  void subdivideFor(uint32_t slot, Sample&& sample, ProgressiveIteration& it);
  void refreshShooterPowers();
  // Per channel, the power shot over the power the iteration's incident irradiance brings.
  glm::dvec3 closedScale(const glm::dvec3& shot) const;
  // Applies an iteration's incident irradiance (incident_, times `scale` per channel) to every
  // element after zeroing the shooter's dB (elements [first, last)), books absorbed and
  // reflected power, refreshes the shooters' powers; returns the power that arrived (W).
  glm::dvec3 applyIncident(const glm::dvec3& scale, uint32_t first, uint32_t last);
};

}  // namespace penumbra
