// Receivers of progressive radiosity and their adaptive subdivision at shadow boundaries
// (Wallner sec. 4), on the chart atlas's hierarchy (geometry/surface_hierarchy.h).
//
//  - Receivers: a cut of the hierarchy (clusters covering every element once). Each receiver
//    gathers at one point: its cluster's area-weighted mean position put on the surface (onto
//    the face among its elements' faces that holds it, or the nearest point of the nearest one:
//    a point on the surface also where a chart bends), its face normal (culling and shadow
//    rays) and the area-weighted mean of its elements' shading normals (the receiver's
//    cosine). Level 0 receivers are the elements themselves. The elements (lightmap
//    texels) under coarser receivers take the gathered values interpolated between the
//    receivers (SurfaceHierarchy::interpolate: bilinear between the centres of equal-level
//    neighbours), the way the texels under one of the paper's triangles hold values
//    interpolated between its vertices. The texels therefore always hold interpolated values,
//    and splitting a receiver "copies its radiosity and residual down to the children by linear
//    interpolation" (sec. 4) with no copy: its elements hold them already.
//  - Subdivision (sec. 4): before a shooter shoots for the first time, each element under a
//    receiver coarser than the finest level is a visibility sample. It counts in n_r when it and
//    the shooter's point assigned to it face each other (the fragments the paper's first pass
//    rasterises without depth test), and in n_v when, besides, the shadow ray between them is
//    unoccluded (the fragments its third pass finds visible). A receiver with n_v < n_r and
//    b_l <= n_v / n_r <= b_u holds a shadow boundary and is replaced by its children, which are
//    tested again on their own elements' samples, down to the finest level. Beyond the paper, a
//    contrast test keeps weak shooters from splitting receivers: each sample also carries the
//    share of its irradiance that the shooter brings, E_s / (E_before + E_s) (E_s unoccluded, from
//    the shooter's power and the disc form factor, E_before what the element has received so
//    far), and a receiver is split only where the mean share over its samples is at least
//    `min_share`. The lights and the first emitters split wherever their shadows fall; a wall's
//    bounce, a tenth of the light already there, does not split receivers for its own soft
//    shadows. min_share = 0 is the paper's test alone.
//  - Balance (Baum et al. 1991, which the paper follows): receivers that touch within a chart
//    differ by at most one level; a coarser neighbour is split until they do. Receivers do not
//    touch across charts (each chart is its own lightmap patch).
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/geometry/surface_hierarchy.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstdint>
#include <span>
#include <vector>

namespace penumbra {

struct RadiositySurface;

// The base level of adaptive receivers when the caller names none: 4 x 4-texel blocks.
inline constexpr int kAdaptiveReceiverLevel = 2;

struct SubdivisionOptions {
  double boundary_low = 0.05;   // b_l
  double boundary_high = 0.95;  // b_u
  int finest_level = 0;         // receivers are split down to this level at most
  double min_share = 0.25;      // the contrast test (see above); 0: the paper's test alone
};

// Checks b_l, b_u (0 <= b_l <= b_u <= 1) and the finest level ([0, 16]).
Status checkSubdivisionOptions(const SubdivisionOptions& options);

class ProgressiveReceivers {
 public:
  // Every chart's clusters of `level` (a chart whose root is finer: its root).
  static ProgressiveReceivers uniform(const RadiositySurface& surface, int level);
  // From the level of the receiver over each element (elementLevels()), as a checkpoint keeps
  // them; fails when they do not describe a cut of the hierarchy.
  static Expected<ProgressiveReceivers> fromElementLevels(const RadiositySurface& surface,
                                                          std::span<const uint8_t> levels);

  size_t size() const { return cut_.size(); }
  std::span<const ClusterRef> clusters() const { return cut_; }
  ClusterRef cluster(size_t k) const { return cut_[k]; }
  const glm::dvec3& position(size_t k) const { return position_[k]; }
  const glm::dvec3& normal(size_t k) const { return normal_[k]; }
  const glm::dvec3& shadingNormal(size_t k) const { return shading_normal_[k]; }
  uint32_t chart(size_t k) const { return chart_[k]; }
  // The atlas face its point lies on and the point's barycentrics (w1, w2) on the face's
  // triangle (the GPU back-projects receivers through them).
  uint32_t face(size_t k) const { return face_[k]; }
  const glm::vec2& barycentric(size_t k) const { return barycentric_[k]; }
  // A receiver's element whose texel the GPU's receiver pass writes: the one nearest its point.
  uint32_t texelElement(size_t k) const { return texel_element_[k]; }
  // The receiver over element e.
  uint32_t owner(size_t e) const { return owner_[e]; }
  // Every receiver is a single element (values need no interpolation).
  bool perElement() const { return per_element_; }
  std::vector<uint8_t> elementLevels() const;
  // Whether element e is a visibility sample of subdivision: its receiver is coarser than
  // `finest_level`.
  bool samples(size_t e, int finest_level) const {
    return cut_[owner_[e]].level > uint32_t(finest_level);
  }

  // Splits the receivers at shadow boundaries from the per-element sample counts (n_r, n_v;
  // zero where an element is no sample) and the shares of the shooter in the samples'
  // irradiance (summed over its counted samples), then restores the balance. Returns the number
  // of receivers split.
  uint32_t subdivide(const RadiositySurface& surface, std::span<const uint16_t> counted,
                     std::span<const uint16_t> visible, std::span<const float> share,
                     const SubdivisionOptions& options);

  // Values per receiver to values per element (interpolated where receivers hold several).
  std::vector<glm::dvec3> toElements(const RadiositySurface& surface,
                                     std::vector<glm::dvec3> values) const;

 private:
  std::vector<ClusterRef> cut_;  // in element order
  std::vector<glm::dvec3> position_, normal_, shading_normal_;
  std::vector<uint32_t> chart_, face_, texel_element_;
  std::vector<glm::vec2> barycentric_;
  std::vector<uint32_t> owner_;  // per element
  bool per_element_ = true;

  void assign(const RadiositySurface& surface, std::vector<ClusterRef> cut);
  // Receiver k's point, face and texel from its cluster's centroid (elements [first, last)).
  void placeOnSurface(const RadiositySurface& surface, size_t k, uint32_t first, uint32_t last);
  // Splits receivers until touching ones differ by at most one level; returns the splits.
  uint32_t balance(const RadiositySurface& surface);
};

}  // namespace penumbra
