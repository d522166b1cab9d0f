// The canonical bounding volume hierarchy: a binary tree built with the binned surface area
// heuristic (Wald, "On fast Construction of SAH-based Bounding Volume Hierarchies", RT 2007).
// Every device converts it to its own layout (design doc sec. 8.4).
#pragma once

#include "penumbra/accel/bounds.h"

#include <glm/vec3.hpp>

#include <cstdint>
#include <span>
#include <vector>

namespace penumbra {

// 32 bytes. Siblings are stored next to each other: an inner node's children are nodes
// `index` and `index + 1`; a leaf holds triangles refs[index, index + count).
struct BvhNode {
  glm::vec3 lo;
  uint32_t index;
  glm::vec3 hi;
  uint32_t count;  // 0 for an inner node

  bool isLeaf() const { return count > 0; }
};
static_assert(sizeof(BvhNode) == 32);

// No tree is deeper than this: the builder switches to median splits deep down, so that
// traversal can use fixed-size stacks.
inline constexpr int kMaxBvhDepth = 96;

struct BvhBuildOptions {
  int bins = 32;                   // SAH bins per axis
  int max_leaf_size = 8;           // a leaf never holds more triangles than this
  float traversal_cost = 1.0f;     // SAH cost of visiting a node ...
  float intersection_cost = 1.0f;  // ... relative to one test of a block of triangles
  int leaf_block = 1;              // triangles tested together (the CPU tests 8 at once)
};

struct Bvh {
  std::vector<BvhNode> nodes;  // nodes[0] is the root
  std::vector<uint32_t> refs;  // triangle indices in leaf order

  size_t memoryBytes() const {
    return nodes.size() * sizeof(BvhNode) + refs.size() * sizeof(uint32_t);
  }
  int depth() const;
  // Surface-area-heuristic cost of the tree (for tests and tuning).
  float sahCost(const BvhBuildOptions& options = {}) const;
};

// Builds over the given triangles (indices into `positions`); degenerate triangles are kept.
// Multithreaded with oneTBB; the result does not depend on the thread count.
Bvh buildBvh(std::span<const glm::vec3> positions, std::span<const glm::uvec3> triangles,
             const BvhBuildOptions& options = {});

}  // namespace penumbra
