// The multiresolution hierarchy over the chart atlas: the radiosity MIP-map of Carr, Hall, Hart
// 2003 (sec. 4.2: MIP levels as clusters of surface; their sec. 5 gathers "from other clusters
// at appropriate levels in the radiosity MIP-map") and Wallner's mipmap over the lightmap
// (sec. 3), as one type that every radiosity and subsurface method shares.
//
//  - Level 0 holds the atlas elements (kInside texels). A cluster of level l holds the elements
//    of one chart whose chart-local texel coordinates fall in one block of 2^l x 2^l texels
//    (clusters never cross charts). Elements are stored in Morton order within each chart
//    (geometry/chart_atlas.h), so every cluster's elements are one contiguous range, and so are
//    its children.
//  - Each cluster keeps what form factors and shooters need: area (m^2), area-weighted mean
//    position, the unit area-weighted mean normal, and its flatness |sum n A| / sum A (1 for a
//    flat cluster, smaller where the surface curves inside it).
//  - The top level of each chart is its root: the first level at which the chart is a single
//    cluster. Levels go up to the largest chart's root; a chart whose root is lower is carried
//    up unchanged (one child), so every level covers every element.
//  - A cut is a set of clusters covering every element exactly once. cut(n) refines, from the
//    roots, the cluster of largest area first until there are at least n clusters (or nothing is
//    left to refine), skipping single-child links: it gives n clusters whatever the triangle
//    count, and exactly the number of charts at the least.
#pragma once

#include "penumbra/geometry/chart_atlas.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstdint>
#include <span>
#include <vector>

namespace penumbra {

struct ClusterLevel {
  // Cluster k holds elements [first[k], first[k + 1]) and children [child_first[k],
  // child_first[k + 1]) of the level below (at level 0: itself, one element).
  std::vector<uint32_t> first;
  std::vector<uint32_t> child_first;
  std::vector<uint32_t> parent;  // in the level above (the top level: itself)
  std::vector<uint32_t> chart;
  std::vector<glm::ivec2> lo, hi;  // atlas texels its block spans (inclusive), within the chart
  std::vector<double> area;
  std::vector<glm::dvec3> position;  // area-weighted mean of its elements' positions
  std::vector<glm::dvec3> normal;    // unit area-weighted mean normal
  std::vector<double> flatness;      // |sum n A| / sum A

  size_t size() const { return chart.size(); }
};

struct ClusterRef {
  uint32_t level = 0;
  uint32_t index = 0;
  bool operator==(const ClusterRef&) const = default;
};

class SurfaceHierarchy {
 public:
  static SurfaceHierarchy build(const ChartAtlas& atlas);

  size_t levelCount() const { return levels_.size(); }
  const ClusterLevel& level(size_t l) const { return levels_[l]; }
  // The chart's root cluster (in the level where it first becomes one cluster).
  ClusterRef root(uint32_t chart) const { return roots_[chart]; }
  size_t chartCount() const { return roots_.size(); }

  // Elements of cluster c: [elementBegin, elementEnd).
  uint32_t elementBegin(ClusterRef c) const { return levels_[c.level].first[c.index]; }
  uint32_t elementEnd(ClusterRef c) const { return levels_[c.level].first[c.index + 1]; }
  // Children one level down (none at level 0).
  std::vector<ClusterRef> children(ClusterRef c) const;

  // At least n clusters covering every element once (fewer when every cluster is a single
  // element), refined largest area first; in element order.
  std::vector<ClusterRef> cut(size_t n) const;

  // Values given per cluster of a cut (cut(n)'s order) interpolated to every element: within
  // each chart, the area-weighted mean of the piecewise-constant cut values over a square window
  // centred on the element, as wide as the square root of its cluster's element count (2^l for a
  // full block of level l). Where neighbouring clusters are full blocks of the same level this
  // is bilinear interpolation between their centres (a box filter of a block's width over
  // blocks); at a chart's boundary the value extends flat. Lookups never cross charts. `atlas` is
  // the one the hierarchy was built from.
  std::vector<glm::dvec3> interpolate(const ChartAtlas& atlas, std::span<const ClusterRef> cut,
                                      std::span<const glm::dvec3> values) const;

 private:
  std::vector<ClusterLevel> levels_;
  std::vector<ClusterRef> roots_;
};

}  // namespace penumbra
