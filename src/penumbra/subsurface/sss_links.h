// Subsurface scattering through hierarchical links over the multiresolution atlas (Carr, Hall,
// Hart 2003, sec. 4.1-4.2.1).
//
// The surface is the chart atlas of the radiosity methods (radiosity/radiosity_surface.h): its
// elements (occupied texels) are the paper's patches P_b, the clusters of its hierarchy
// (geometry/surface_hierarchy.h) the MIP levels P_l. Eq. 9 discretises eq. 7:
//
//   B_i = sum_j F_ij E_j,    F_ij = 1 / A_i int_{P_i} int_{P_j} R_d(|x_i - x_j|) dx_j dx_i  (eq.
//   10)
//
// with E_j the irradiance transmitted into patch j (pass 1), R_d the dipole profile of the
// medium (kernels/dipole.h) and B_i the scattered radiosity under patch i. For a cluster j, E_j is
// the area-weighted mean of its elements' (the MIP-mapped radiosity map), so F_ij A-weights the
// whole cluster.
//
// The link tree. Light scatters only within one translucent object: the elements of one
// translucent material (give two objects two materials to keep them apart). Above its charts'
// roots each object gets a binary tree (median splits of the roots' positions along their
// widest axis), so that every object has one root, as the paper's atlas hierarchy does. Nodes
// are the hierarchy's clusters of every level (level l, cluster k is node levelOffset(l) + k;
// level 0 nodes are the elements) followed by the top trees. Chains of single children (charts
// carried up unchanged) are skipped: a node's children are its first descendants with more than
// one child, or elements.
//
// Throughput F(i, n) from element i to node n: the point form A_n R_d(d) with d the distance
// between their centres when n is far (d > kNearFactor (r_i + r_n), r the bounding radii), else
// the sum over n's children. Between an element and itself or a touching one (kTouchFactor), R_d
// integrated over the other's texel square in polar coordinates (exact in r, however sharply it
// peaks) from 4 x 4 (2 x 2) points of the first, weighted by the share of the square the element
// covers; between other near elements a quadrature of 2 x 2 points on each texel square. The
// squares are laid out with the texel's own axes on the surface.
//
// Links (sec. 4.2.1): adaptive, per element, top down from the object's root by a priority queue
// on the throughput (summed over RGB) times the node's radius: the first node is replaced by its
// children while the links fit in L, and nodes under a share of 0.6 / L^2 of the element's
// throughput go to one remainder link to the root; or non-adaptive: every node of the object at
// one level (its charts' roots where a chart ends below that level). F is stored per colour
// channel (the paper kept one scalar to save space; channels of one medium differ by factors of
// ten), with the F-weighted centroid of the node, where the gather reads the node's irradiance
// (mipMapIrradiance: mean plus gradient, the first-order form of the paper's bilinear lookups).
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/kernels/dipole.h"
#include "penumbra/radiosity/radiosity_surface.h"

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

namespace penumbra {

// Far-field test: nodes whose centres are further apart than this many times the sum of their
// bounding radii exchange by the point form.
inline constexpr double kNearFactor = 4.0;
// Texels closer than this many times the sum of their radii touch: their factor integrates R_d
// over the square exactly in r (it may peak within one texel); further near texels use points.
inline constexpr double kTouchFactor = 1.5;

struct SssTree {
  // Per node.
  std::vector<glm::dvec3> position;  // area-weighted mean of its elements' points (m)
  std::vector<double> area;          // m^2
  std::vector<double> radius;        // bounding radius about `position` (m)
  std::vector<int32_t> object;       // translucent object, or -1
  // Children of node n: child_index[child_first[n] .. child_first[n + 1]) (none for elements).
  std::vector<uint32_t> child_first;
  std::vector<uint32_t> child_index;
  // Node ranges: hierarchy level l is [level_offset[l], level_offset[l + 1]); the top trees
  // follow, from level_offset.back() to nodeCount(), children before parents.
  std::vector<uint32_t> level_offset;
  std::vector<uint32_t> object_root;      // per object
  std::vector<uint32_t> object_material;  // per object: its Scene::materials index
  // Per element: a step of one texel along atlas x and y on the surface (m), for quadrature.
  std::vector<glm::dvec3> axis_x, axis_y;
  // Per node with children: the inverse of sum_c a_c d_c d_c^T (d_c = child position - node
  // position), regularised, for the least-squares gradient of the MIP-map (mipMapIrradiance).
  std::vector<glm::mat3> moment_inverse;

  size_t nodeCount() const { return position.size(); }
  size_t elementCount() const { return level_offset.size() > 1 ? level_offset[1] : 0; }
  size_t objectCount() const { return object_root.size(); }
  std::span<const uint32_t> children(uint32_t n) const {
    return {child_index.data() + child_first[n], child_index.data() + child_first[n + 1]};
  }
};

// Builds the tree over `surface` (whose materials are `materials`: a material with a
// subsurface block makes an object).
SssTree buildSssTree(const RadiositySurface& surface, std::span<const Material> materials);

// The media of the tree's objects, in object order.
std::vector<Dipole> objectMedia(const SssTree& tree, std::span<const Material> materials);

// F(i, n) (eq. 10), RGB, for element i and any node n of i's object.
glm::dvec3 throughputFactor(const SssTree& tree, const Dipole& medium, uint32_t element,
                            uint32_t node);

struct SssLinkOptions {
  int links = 16;  // L, links per element (adaptive)
  int level = -1;  // >= 0: non-adaptive, every node of the object at this hierarchy level
};

struct SssLinks {
  uint32_t per_element = 0;       // slots per element; unused slots hold factor 0
  std::vector<uint32_t> node;     // element e's links: [e * per_element, (e + 1) * per_element)
  std::vector<glm::vec3> factor;  // F per link, RGB
  // Per link: where in the node the throughput falls, its F-weighted centroid relative to the
  // node's position (m); the gather reads the node's irradiance there (see gatherScattered).
  std::vector<glm::vec3> offset;
  double seconds = 0.0;  // time to build them
};

// Links for every element of a translucent object (other elements get none). `progress` is
// called with the elements done so far (from any thread).
SssLinks buildSssLinks(const SssTree& tree, std::span<const Dipole> media,
                       const SssLinkOptions& options,
                       const std::function<void(size_t)>& progress = nullptr);

// The MIP-mapped radiosity map: per node the area-weighted mean of `element_values` over its
// elements (elements keep theirs).
std::vector<glm::vec3> nodeMeans(const SssTree& tree, std::span<const glm::vec3> element_values);

// The MIP-map with a first-order term: per node its mean and the least-squares gradient of its
// children's means about it (RGB per metre along each axis: gradient * d is the change over d;
// zero for elements). This is what the paper's bilinear (u, v, LOD) lookups give a link: the
// irradiance where in the cluster its throughput falls, not the cluster's average.
struct SssNodeIrradiance {
  std::vector<glm::vec3> mean;
  std::vector<glm::mat3> gradient;
};
SssNodeIrradiance mipMapIrradiance(const SssTree& tree, std::span<const glm::vec3> element_values);

// Pass 2 (eq. 9): B_i = sum over element i's links of F E_node, E_node read at the link's
// offset (mean + gradient * offset, not below zero).
void gatherScattered(const SssLinks& links, const SssNodeIrradiance& node_irradiance,
                     std::span<glm::vec3> scattered);

// The reference: B_i = sum over every element j of i's object of F(i, j) E_j (O(N^2)).
std::vector<glm::vec3> gatherAllPairs(const SssTree& tree, std::span<const Dipole> media,
                                      std::span<const glm::vec3> element_irradiance);

}  // namespace penumbra
