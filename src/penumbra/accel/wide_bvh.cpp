#include "penumbra/accel/wide_bvh.h"

#include "penumbra/core/check.h"

#include <algorithm>
#include <limits>

namespace penumbra {

namespace {

int32_t leafRef(const BvhNode& n, Bvh8& out) {
  const uint32_t index = uint32_t(out.leaves.size());
  PENUMBRA_CHECK_MSG(n.count <= 15 && index < (1u << 27), "leaf {} of {}", index, n.count);
  out.leaves.push_back({n.index, n.count});
  return ~int32_t((index << 4) | n.count);
}

// Builds the wide node for binary inner node `b`, recursively; returns its index.
int32_t collapse(const Bvh& bvh, uint32_t b, Bvh8& out) {
  // Gather up to eight binary descendants, opening the largest inner one each time.
  uint32_t kids[8] = {bvh.nodes[b].index, bvh.nodes[b].index + 1};
  int n = 2;
  while (n < 8) {
    int best = -1;
    float best_area = -1.0f;
    for (int i = 0; i < n; ++i) {
      const BvhNode& c = bvh.nodes[kids[i]];
      if (c.isLeaf()) continue;
      const float a = Bounds3{c.lo, c.hi}.area();
      if (a > best_area) best_area = a, best = i;
    }
    if (best < 0) break;
    const uint32_t open = kids[best];
    kids[best] = bvh.nodes[open].index;
    kids[n++] = bvh.nodes[open].index + 1;
  }
  const int32_t index = int32_t(out.nodes.size());
  out.nodes.emplace_back();
  for (int i = 0; i < 8; ++i) {
    Bvh8Node& node = out.nodes[size_t(index)];
    if (i >= n) {
      // Empty slot: an inverted box (lo = +inf, hi = -inf) fails every slab test.
      node.lo_x[i] = node.lo_y[i] = node.lo_z[i] = std::numeric_limits<float>::infinity();
      node.hi_x[i] = node.hi_y[i] = node.hi_z[i] = -std::numeric_limits<float>::infinity();
      node.child[i] = Bvh8Node::kEmpty;
      continue;
    }
    const BvhNode& c = bvh.nodes[kids[i]];
    node.lo_x[i] = c.lo.x, node.lo_y[i] = c.lo.y, node.lo_z[i] = c.lo.z;
    node.hi_x[i] = c.hi.x, node.hi_y[i] = c.hi.y, node.hi_z[i] = c.hi.z;
    if (c.isLeaf()) {
      node.child[i] = leafRef(c, out);
    } else {
      const int32_t child = collapse(bvh, kids[i], out);  // may reallocate out.nodes
      out.nodes[size_t(index)].child[i] = child;
    }
  }
  return index;
}

}  // namespace

Bvh8 collapseToBvh8(const Bvh& bvh) {
  Bvh8 out;
  if (bvh.nodes.empty()) return out;
  if (bvh.nodes[0].isLeaf()) {
    out.root = leafRef(bvh.nodes[0], out);
    return out;
  }
  out.nodes.reserve(bvh.nodes.size() / 4 + 1);
  out.root = collapse(bvh, 0, out);
  return out;
}

}  // namespace penumbra
