// The CPU layout of the BVH: 8-wide nodes with their children's boxes stored as structures of
// arrays, so one AVX2 instruction sequence tests a ray against all eight (the layout of
// Embree's BVH8, Wald et al. 2014). Converted from the canonical binary BVH by the optimal
// collapse of Ylitie, Karras and Laine (HPG 2017, sec. 3.1): a dynamic programme over the binary
// tree that chooses which binary nodes become wide nodes so that their total surface area, the
// part of the SAH cost the grouping controls, is least (wide_bvh.cpp). Leaves stay those of the
// canonical tree.
#pragma once

#include "penumbra/accel/bvh.h"

#include <cstdint>
#include <vector>

namespace penumbra {

// 256 bytes: 6 x 8 floats of child boxes, 8 child references.
struct alignas(64) Bvh8Node {
  float lo_x[8], hi_x[8], lo_y[8], hi_y[8], lo_z[8], hi_z[8];
  // >= 0: index of an inner node. < 0: a leaf, ~child = (leaf index << 4) | triangle count.
  // Unused slots hold kEmpty and a box no ray can hit.
  int32_t child[8];

  static constexpr int32_t kEmpty = ~int32_t(0);  // a leaf with zero triangles
};
static_assert(sizeof(Bvh8Node) == 256);

inline bool bvh8IsLeaf(int32_t child) {
  return child < 0;
}
inline uint32_t bvh8LeafIndex(int32_t child) {
  return uint32_t(~child) >> 4;
}
inline uint32_t bvh8LeafCount(int32_t child) {
  return uint32_t(~child) & 15u;
}

// What the CPU traverses, 128 bytes: the eight child boxes quantised to 8 bits per plane in the
// frame of the node's own box (Ylitie, Karras, Laine 2017, sec. 3.2), so a node is two cache
// lines instead of four. A plane is origin + q * scale with scale a power of two: the product is
// exact and the sum rounds once, the same in every kernel. Planes are rounded outwards when the
// node is made and checked in that arithmetic, so each dequantised box contains its child's
// box: the slab test on them culls nothing the float boxes would keep (it may enter a child a
// little more often, never less).
struct alignas(64) Bvh8QNode {
  int32_t child[8];  // as Bvh8Node::child (first: one aligned vector load)
  float origin[3];   // the low corner of the union of the children's boxes
  float scale[3];    // powers of two
  uint8_t lo_x[8], hi_x[8], lo_y[8], hi_y[8], lo_z[8], hi_z[8];
  uint8_t valid;  // bit i: slot i holds a child
  uint8_t pad[23];
};
static_assert(sizeof(Bvh8QNode) == 128);

// The quantised form of `node`.
Bvh8QNode quantizeBvh8Node(const Bvh8Node& node);

struct Bvh8 {
  struct Leaf {
    uint32_t first;  // into Bvh::refs
    uint32_t count;
  };
  std::vector<Bvh8Node> nodes;      // nodes[0] is the root (when the tree is not a single leaf)
  std::vector<Leaf> leaves;         // in depth-first order
  int32_t root = Bvh8Node::kEmpty;  // the root reference: an inner node or a leaf
};

// Requires leaves of at most 15 triangles and fewer than 2^27 leaves.
Bvh8 collapseToBvh8(const Bvh& bvh);

}  // namespace penumbra
