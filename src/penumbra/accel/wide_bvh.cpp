#include "penumbra/accel/wide_bvh.h"

#include "penumbra/core/check.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace penumbra {

namespace {

int32_t leafRef(const BvhNode& n, Bvh8& out) {
  const uint32_t index = uint32_t(out.leaves.size());
  PENUMBRA_CHECK_MSG(n.count <= 15 && index < (1u << 27), "leaf {} of {}", index, n.count);
  out.leaves.push_back({n.index, n.count});
  return ~int32_t((index << 4) | n.count);
}

// The optimal collapse of Ylitie, Karras and Laine, "Efficient Incoherent Ray Traversal on
// GPUs Through Compressed Wide BVHs" (HPG 2017, sec. 3.1), without their leaf merging (leaves
// stay the canonical tree's, so every device sees the same leaves). Every binary leaf is a
// child slot of exactly one wide node whatever the grouping, so the SAH cost that varies is
// that of the wide inner nodes: sum of their areas. cost(n, i) is the least such cost of
// representing the binary subtree n as at most i slots of its parent:
//   slot(n)    = 0 for a leaf, area(n) + split(n, 8) for an inner node (n becomes a wide node),
//   split(n,i) = min over k of cost(left, k) + cost(right, i - k),
//   cost(n, 1) = slot(n),  cost(n, i) = min(cost(n, i - 1), split(n, i)).
// The greedy collapse (open the largest child until eight) leaves small wide nodes at the
// bottom of the tree: on the bunny its nodes averaged 3.7 children, this one's about 6.
class Collapser {
 public:
  Collapser(const Bvh& bvh, Bvh8& out)
      : bvh_(bvh), out_(out), cost_(bvh.nodes.size()), split_k_(bvh.nodes.size()) {
    solve(0);
  }

  // Builds the wide node for binary inner node `b` and, recursively, those below it; returns
  // its index. A node's leaf blocks are numbered consecutively and its inner children are
  // stored next to each other, so the children a ray enters tend to share cache lines and
  // pages, and the hardware prefetchers see runs.
  int32_t emit(uint32_t b) {
    const int32_t index = int32_t(out_.nodes.size());
    out_.nodes.emplace_back();
    fill(b, index);
    return index;
  }

 private:
  void fill(uint32_t b, int32_t index) {
    uint32_t kids[8];
    int n = 0;
    gather(b, 8, kids, n, true);
    int32_t refs[8];
    for (int i = 0; i < n; ++i) {
      const BvhNode& c = bvh_.nodes[kids[i]];
      if (c.isLeaf()) refs[i] = leafRef(c, out_);
    }
    for (int i = 0; i < n; ++i) {
      if (bvh_.nodes[kids[i]].isLeaf()) continue;
      refs[i] = int32_t(out_.nodes.size());
      out_.nodes.emplace_back();
    }
    Bvh8Node& node = out_.nodes[size_t(index)];
    for (int i = 0; i < 8; ++i) {
      if (i >= n) {
        // Empty slot: an inverted box (lo = +inf, hi = -inf) fails every slab test.
        node.lo_x[i] = node.lo_y[i] = node.lo_z[i] = std::numeric_limits<float>::infinity();
        node.hi_x[i] = node.hi_y[i] = node.hi_z[i] = -std::numeric_limits<float>::infinity();
        node.child[i] = Bvh8Node::kEmpty;
        continue;
      }
      const BvhNode& c = bvh_.nodes[kids[i]];
      node.lo_x[i] = c.lo.x, node.lo_y[i] = c.lo.y, node.lo_z[i] = c.lo.z;
      node.hi_x[i] = c.hi.x, node.hi_y[i] = c.hi.y, node.hi_z[i] = c.hi.z;
      node.child[i] = refs[i];
    }
    for (int i = 0; i < n; ++i) {
      if (!bvh_.nodes[kids[i]].isLeaf()) fill(kids[i], refs[i]);  // may reallocate out_.nodes
    }
  }

  // cost_[n][i - 1] = cost(n, i); split_k_[n][i - 1] = the k of split(n, i), or 0 when
  // cost(n, i) is reached with fewer slots or as one slot.
  void solve(uint32_t n) {
    const BvhNode& node = bvh_.nodes[n];
    std::array<float, 8>& c = cost_[n];
    if (node.isLeaf()) {
      c.fill(0.0f);
      split_k_[n].fill(0);
      return;
    }
    const uint32_t l = node.index, r = node.index + 1;
    solve(l);
    solve(r);
    std::array<float, 8> split;
    std::array<uint8_t, 8> split_k{};
    split[0] = std::numeric_limits<float>::infinity();
    for (int i = 2; i <= 8; ++i) {
      float best = std::numeric_limits<float>::infinity();
      for (int k = 1; k < i; ++k) {
        const float v = cost_[l][size_t(k - 1)] + cost_[r][size_t(i - k - 1)];
        if (v < best) best = v, split_k[size_t(i - 1)] = uint8_t(k);
      }
      split[size_t(i - 1)] = best;
    }
    c[0] = Bounds3{node.lo, node.hi}.area() + split[7];
    split_k_[n][0] = 0;
    for (int i = 2; i <= 8; ++i) {
      const bool use_split = split[size_t(i - 1)] < c[size_t(i - 2)];
      c[size_t(i - 1)] = use_split ? split[size_t(i - 1)] : c[size_t(i - 2)];
      split_k_[n][size_t(i - 1)] = use_split ? split_k[size_t(i - 1)] : 0;
    }
  }

  // Appends the slots that represent subtree `n` with at most `slots` slots. `open` forces an
  // inner node to be opened (it is the wide node being built, not one of its children).
  void gather(uint32_t n, int slots, uint32_t* kids, int& count, bool open) {
    const BvhNode& node = bvh_.nodes[n];
    if (open) {
      const int k = split_k_[n][7] ? split_k_[n][7] : bestSplit(n, 8);
      gather(node.index, k, kids, count, false);
      gather(node.index + 1, 8 - k, kids, count, false);
      return;
    }
    while (slots > 1 && split_k_[n][size_t(slots - 1)] == 0) --slots;
    if (slots == 1 || node.isLeaf()) {
      kids[count++] = n;
      return;
    }
    const int k = split_k_[n][size_t(slots - 1)];
    gather(node.index, k, kids, count, false);
    gather(node.index + 1, slots - k, kids, count, false);
  }

  // The k of split(n, 8), for a node whose cost(n, 8) did not come from splitting.
  int bestSplit(uint32_t n, int slots) const {
    const uint32_t l = bvh_.nodes[n].index, r = l + 1;
    int best_k = 1;
    float best = std::numeric_limits<float>::infinity();
    for (int k = 1; k < slots; ++k) {
      const float v = cost_[l][size_t(k - 1)] + cost_[r][size_t(slots - k - 1)];
      if (v < best) best = v, best_k = k;
    }
    return best_k;
  }

  const Bvh& bvh_;
  Bvh8& out_;
  std::vector<std::array<float, 8>> cost_;
  std::vector<std::array<uint8_t, 8>> split_k_;
};

}  // namespace

Bvh8 collapseToBvh8(const Bvh& bvh) {
  Bvh8 out;
  if (bvh.nodes.empty()) return out;
  if (bvh.nodes[0].isLeaf()) {
    out.root = leafRef(bvh.nodes[0], out);
    return out;
  }
  out.nodes.reserve(bvh.nodes.size() / 8 + 1);
  Collapser collapser(bvh, out);
  out.root = collapser.emit(0);
  return out;
}

namespace {

// The plane of quantised value q, in the arithmetic every traversal kernel uses.
inline float dequantize(float origin, float scale, int q) {
  return origin + float(q) * scale;
}

}  // namespace

Bvh8QNode quantizeBvh8Node(const Bvh8Node& node) {
  Bvh8QNode q{};
  const float* lo[3] = {node.lo_x, node.lo_y, node.lo_z};
  const float* hi[3] = {node.hi_x, node.hi_y, node.hi_z};
  uint8_t* qlo[3] = {q.lo_x, q.lo_y, q.lo_z};
  uint8_t* qhi[3] = {q.hi_x, q.hi_y, q.hi_z};
  for (int i = 0; i < 8; ++i) q.child[i] = node.child[i];
  for (int i = 0; i < 8; ++i) {
    if (node.child[i] != Bvh8Node::kEmpty) q.valid |= uint8_t(1u << i);
  }
  for (int a = 0; a < 3; ++a) {
    float box_lo = std::numeric_limits<float>::infinity();
    float box_hi = -std::numeric_limits<float>::infinity();
    for (int i = 0; i < 8; ++i) {
      if (!(q.valid >> i & 1)) continue;
      box_lo = std::min(box_lo, lo[a][i]);
      box_hi = std::max(box_hi, hi[a][i]);
    }
    if (q.valid == 0) box_lo = box_hi = 0.0f;
    // The smallest power of two whose 255 steps reach the top of the box (at least 2^-100, so
    // products stay normal numbers).
    const double extent = double(box_hi) - double(box_lo);
    float scale = std::ldexp(
        1.0f, std::max(-100, extent > 0.0 ? int(std::ceil(std::log2(extent / 255.0))) : -100));
    while (dequantize(box_lo, scale, 255) < box_hi) scale *= 2.0f;
    q.origin[a] = box_lo;
    q.scale[a] = scale;
    for (int i = 0; i < 8; ++i) {
      if (!(q.valid >> i & 1)) {
        qlo[a][i] = 255, qhi[a][i] = 0;  // never entered: the valid mask excludes the slot too
        continue;
      }
      int l = int(std::clamp(std::floor((double(lo[a][i]) - box_lo) / scale), 0.0, 255.0));
      while (l > 0 && dequantize(box_lo, scale, l) > lo[a][i]) --l;
      int h = int(std::clamp(std::ceil((double(hi[a][i]) - box_lo) / scale), 0.0, 255.0));
      while (h < 255 && dequantize(box_lo, scale, h) < hi[a][i]) ++h;
      PENUMBRA_CHECK(dequantize(box_lo, scale, l) <= lo[a][i] &&
                     dequantize(box_lo, scale, h) >= hi[a][i]);
      qlo[a][i] = uint8_t(l), qhi[a][i] = uint8_t(h);
    }
  }
  return q;
}

}  // namespace penumbra
