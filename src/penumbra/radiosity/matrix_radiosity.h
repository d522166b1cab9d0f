// Matrix radiosity as a user runs it (Carr, Hall, Hart 2003, sec. 3) on the radiosity surface
// (radiosity/radiosity_surface.h): the unknowns are the clusters of a cut through the
// multiresolution hierarchy, as many as asked whatever the triangle count; the form factors
// between them are computed once (radiosity/form_factors.h); the system is solved, and solved
// again after emissions or reflectances change (dynamic relighting: the form factors, which hold
// all the geometry and visibility, are kept; the previous solution is the starting point).
//
//  - The system, per cluster c (area-weighted means over its elements):
//      B_c = E_c + rho_c (D_c + S_c + sum_j F_cj B_j),
//    D the direct irradiance of the point, spot and directional lights (raytrace/lights.h; the
//    sun is one), computed at every element with a Ray Engine shadow ray; S the direct
//    irradiance of the sky and its ground through the openings and straight, or of the uniform
//    environment (radiosity/outside_light.h, eq. 1-2 there), at every element. Both enter the
//    right-hand side E' = E + rho (D + S) of M B = E', so the residual that ends the solve
//    (matrix_solver.h) measures their light as the emitters'.
//  - Display and bake (the solution interpolated down to level 0): each element takes
//      B_e = E_e + rho_e (D_e + S_e + G_e + H_e),
//    with its own emission, reflectance and direct light (sharp shadows of point lights and of
//    the sky's window patches); G_e
//    the light gathered at the element itself from the emitting clusters (those with E > 0 when
//    built, if they cover at most kElementGatherArea of the surface and elements x emitters <=
//    kElementGatherBudget, else none), with element-to-cluster form factors and their own shadow
//    rays (FormFactorOptions::element_rays), so that the shadows of small area lights are as
//    sharp as the lightmap too; and H_e the rest of the gathered irradiance, H_c
//    = (F B)_c minus the emitters' part, interpolated from the clusters
//    (SurfaceHierarchy::interpolate) with the near field gathered at the element itself:
//      H_e = v_e interp((H - N) / vbar)_e + N_e,
//    from kSubClusterRays cosine-distributed rays per element of one size sqrt(A_c) of its
//    cluster: v_e the share that travel that far without a hit, N_e the mean over the rays of
//    the radiosity B of the clusters they land on (0 for a black back face; emitting clusters
//    are G_e's), vbar_c and N_c their area-weighted means over the cluster. The far field
//    (H - N) / vbar is interpolated as a ratio, interp(H - N) / interp(vbar) with the same
//    weights, so where nothing is near (v = 1, N = 0) H_e is the plain interpolation. A
//    cluster's solve resolves nothing nearer than its own size: a ceiling panel 1 cm under the
//    ceiling hides the texels above it from everything, and plain interpolation spread light
//    onto them and darkened the ring around the panel by up to 40% (the textured room); in a
//    corner, the near wall's own light replaces what it hides. The lightmap is the
//    chart atlas's, as every radiosity method's.
//  - Two-sided surfaces have clusters on both sides (each chart lies on one side).
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/radiosity/form_factors.h"
#include "penumbra/radiosity/matrix_solver.h"
#include "penumbra/radiosity/radiosity_surface.h"
#include "penumbra/scene/scene.h"

#include <functional>
#include <optional>
#include <span>
#include <vector>

namespace penumbra {

// Rays per element for the sub-cluster visibility v_e (see the file comment).
inline constexpr int kSubClusterRays = 16;

// Element-to-emitter form factors computed at most (elements x emitting clusters).
inline constexpr uint64_t kElementGatherBudget = 10'000'000;
// Emitters are gathered at the elements only while they cover at most this fraction of the
// surface (small luminaires; a scene that glows all over gains nothing from it).
inline constexpr double kElementGatherArea = 0.1;

// Clusters (unknowns) when the caller names no count. On the Cornell box at 5,000 the image's
// mean is 0.986 of the path tracer's and every block of a 4 x 4 grid within 4.3% of it (2,000:
// 0.982 and 6.3%), for about 1.5 s of form factors on two cores.
inline constexpr uint32_t kMatrixDefaultElements = 5000;

struct MatrixRadiosityOptions {
  uint32_t elements = kMatrixDefaultElements;  // clusters of the cut: the unknowns
  LightmapResolution lightmap;                 // the elements the solution is shown on
  FormFactorOptions form_factors;
  MatrixPrecision precision = MatrixPrecision::kFp32;
  bool shading_normals = true;  // for the lights' direct term (RadiositySurface)
};

// Bytes the method needs for n clusters at a precision (form factors in fp32 while they are
// computed, the stored matrix) on a process holding `rows` of the n rows (all by default; a
// rank's block over several): checked before anything N^2 is allocated.
uint64_t matrixRadiosityBytes(uint64_t n, MatrixPrecision precision, uint64_t rows = ~0ull);

struct MatrixRadiosity {
  RadiositySurface surface;
  std::vector<ClusterRef> clusters;  // the cut: cluster k is unknown k, in element order
  std::vector<double> cluster_area;  // m^2
  std::vector<glm::dvec3> direct;    // per element: the lights' irradiance D_e (W m^-2)
  // Per element: the sky's or the environment's irradiance S_e (W m^-2), empty when the scene
  // has neither; and the power it brings to the surfaces (sum S_e A_e, W), for the stats.
  std::vector<glm::dvec3> outside;
  glm::dvec3 outside_power{0.0};
  bool light_visibility = true;  // shadow rays for D_e (FormFactorOptions::visibility)
  // The emitting clusters gathered at every element, and their form factors:
  // element_ff[e * emitters.size() + s] = F(element e -> cluster emitters[s]).
  std::vector<uint32_t> emitters;
  std::vector<float> element_ff;
  // The near field (see the file comment): per element, where each of its kSubClusterRays rays
  // landed (kFree: nowhere within reach; -1: a side without elements; else the element), and
  // each element's cluster. Empty without visibility.
  static constexpr int32_t kFree = -2;
  std::vector<int32_t> near_hit;
  std::vector<uint32_t> element_cluster;
  std::optional<RadiositySystem> system;  // always set once built
  // The ranks that share the system (each holds a block of rows; docs/scaling.md); null: one
  // process. solve() and elementRadiosity() are then collective, and every rank gets the result.
  Communicator* comm = nullptr;
  std::vector<glm::vec3> radiosity;  // B per cluster (W m^-2), the latest solution
  FormFactorStats form_factor_stats;

  size_t size() const { return clusters.size(); }
  // Whether cluster k's own elements emit (E_e > 0, not only reflected light).
  bool emittedByMaterial(size_t k) const;
  // Sets reflectance and emission, per element and per cluster, from the materials (indexed as
  // the scene's), with the lights' and the outside's direct terms reflected.
  void applyMaterials(std::span<const Material> materials);
  // The lights' direct irradiance D_e at every element again, for lights that moved or changed
  // (shadow rays as at build time); applyMaterials then sets the system's emission from it.
  // Returns the rays traced.
  uint64_t setLights(std::span<const Light> lights);
  // Solves from the current `radiosity` (zeros at first, the previous solution afterwards).
  SolveStats solve(const SolveOptions& options,
                   const std::function<void(int, double)>& after_iteration = {});
  // B per element (see the file comment), from the current solution; with `interpolate` false
  // each element takes its cluster's gathered irradiance as it is (the clusters show as blocks).
  std::vector<glm::dvec3> elementRadiosity(bool interpolate = true) const;
  // Outgoing radiance B / pi per atlas texel (RadiositySurface::radianceImage).
  Image radianceImage(bool interpolate = true) const;
};

// The checks buildMatrixRadiosity makes before any work (options in range, memory for the system
// and the lightmap), for callers that want to refuse early; over `ranks` ranks the memory is
// this rank's share of the rows.
Status checkMatrixRadiosity(const Scene& scene, const MatrixRadiosityOptions& options,
                            int ranks = 1);

// Builds the surface, picks the cut and computes the form factors (`on_row(rows_done, rows)`
// reports progress). Refuses, with the amount, a system that would not fit in memory.
// Over several ranks (`comm`, collective: every rank builds the same surface and cut) each rank
// holds and computes a block of the rows (radiosity/form_factors.h), and the emitters' element
// form factors are shared out too.
Expected<MatrixRadiosity> buildMatrixRadiosity(
    const Scene& scene, const MatrixRadiosityOptions& options,
    const std::function<void(size_t, size_t)>& on_row = {}, Communicator* comm = nullptr);

}  // namespace penumbra
