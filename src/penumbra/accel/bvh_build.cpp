#include "penumbra/accel/bvh.h"

#include "penumbra/core/check.h"
#include "penumbra/core/parallel.h"

#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>

namespace penumbra {

namespace {

struct BuildRef {
  Bounds3 bounds;
  glm::vec3 centroid;
  uint32_t triangle;
};

constexpr int kMaxBins = 64;
constexpr int kMaxSahDepth = 64;             // below this depth only median splits (see build())
constexpr size_t kParallelThreshold = 4096;  // subtrees larger than this build as tasks

class Builder {
 public:
  Builder(std::vector<BuildRef>& refs, const BvhBuildOptions& options, std::vector<BvhNode>& nodes)
      : refs_(refs), options_(options), nodes_(nodes) {}

  // Allocates `n` consecutive node slots.
  uint32_t allocate(uint32_t n) { return next_node_.fetch_add(n); }
  uint32_t used() const { return next_node_.load(); }

  void build(uint32_t node_index, uint32_t begin, uint32_t end, int depth) {
    BvhNode& node = nodes_[node_index];
    Bounds3 bounds, centroid_bounds;
    for (uint32_t i = begin; i < end; ++i) {
      bounds.extend(refs_[i].bounds);
      centroid_bounds.extend(refs_[i].centroid);
    }
    node.lo = bounds.lo;
    node.hi = bounds.hi;
    const uint32_t count = end - begin;

    uint32_t mid = 0;
    if (depth >= kMaxSahDepth && count > uint32_t(options_.max_leaf_size)) {
      // Pathological input: switch to object-median splits, which bound the remaining depth by
      // log2(count), so traversal stacks (kMaxBvhDepth) never overflow.
      mid = medianSplit(centroid_bounds, begin, end);
    } else if (!findSplit(bounds, centroid_bounds, begin, end, mid)) {
      if (count <= uint32_t(options_.max_leaf_size)) {
        node.index = begin;
        node.count = count;
        return;
      }
      // Too many for a leaf but no useful split (coincident centroids): halve in place.
      mid = begin + count / 2;
    }
    const uint32_t left = allocate(2);
    node.index = left;
    node.count = 0;
    if (count > kParallelThreshold) {
      tbb::parallel_invoke([&] { build(left, begin, mid, depth + 1); },
                           [&] { build(left + 1, mid, end, depth + 1); });
    } else {
      build(left, begin, mid, depth + 1);
      build(left + 1, mid, end, depth + 1);
    }
  }

 private:
  uint32_t medianSplit(const Bounds3& centroid_bounds, uint32_t begin, uint32_t end) {
    const glm::vec3 e = centroid_bounds.extent();
    const int axis = (e.x >= e.y && e.x >= e.z) ? 0 : (e.y >= e.z ? 1 : 2);
    const uint32_t mid = begin + (end - begin) / 2;
    std::nth_element(refs_.begin() + begin, refs_.begin() + mid, refs_.begin() + end,
                     [axis](const BuildRef& a, const BuildRef& b) {
                       return a.centroid[axis] < b.centroid[axis];
                     });
    return mid;
  }

  // Binned SAH (Wald 2007): returns false when a leaf is cheaper than every split.
  bool findSplit(const Bounds3& bounds, const Bounds3& centroid_bounds, uint32_t begin,
                 uint32_t end, uint32_t& mid) {
    const uint32_t count = end - begin;
    if (count <= 1) return false;
    const int bins = std::clamp(options_.bins, 2, kMaxBins);
    const glm::vec3 extent = centroid_bounds.extent();
    float best_cost = std::numeric_limits<float>::infinity();
    int best_axis = -1, best_bin = 0;
    for (int axis = 0; axis < 3; ++axis) {
      if (!(extent[axis] > 0.0f)) continue;
      std::array<Bounds3, kMaxBins> bin_bounds;
      std::array<uint32_t, kMaxBins> bin_count{};
      const float scale = float(bins) / extent[axis];
      for (uint32_t i = begin; i < end; ++i) {
        const int b = binOf(refs_[i].centroid[axis], centroid_bounds.lo[axis], scale, bins);
        bin_bounds[b].extend(refs_[i].bounds);
        ++bin_count[b];
      }
      // Sweep from the right, then from the left, evaluating every plane between bins.
      std::array<float, kMaxBins> right_cost{};
      Bounds3 acc;
      uint32_t n = 0;
      for (int b = bins - 1; b > 0; --b) {
        acc.extend(bin_bounds[b]);
        n += bin_count[b];
        right_cost[b] = acc.area() * blocks(n);
      }
      acc = Bounds3();
      n = 0;
      for (int b = 0; b < bins - 1; ++b) {
        acc.extend(bin_bounds[b]);
        n += bin_count[b];
        const float cost = acc.area() * blocks(n) + right_cost[b + 1];
        if (n > 0 && n < count && cost < best_cost) {
          best_cost = cost;
          best_axis = axis;
          best_bin = b;
        }
      }
    }
    if (best_axis < 0) return false;
    const float parent_area = bounds.area();
    const float split_cost =
        options_.traversal_cost +
        options_.intersection_cost * (parent_area > 0.0f ? best_cost / parent_area : blocks(count));
    const float leaf_cost = options_.intersection_cost * blocks(count);
    if (split_cost >= leaf_cost && count <= uint32_t(options_.max_leaf_size)) return false;

    const float scale = float(bins) / extent[best_axis];
    const float lo = centroid_bounds.lo[best_axis];
    auto it = std::partition(refs_.begin() + begin, refs_.begin() + end, [&](const BuildRef& r) {
      return binOf(r.centroid[best_axis], lo, scale, bins) <= best_bin;
    });
    mid = uint32_t(it - refs_.begin());
    PENUMBRA_CHECK_MSG(mid > begin && mid < end, "split {} of [{}, {})", mid, begin, end);
    return true;
  }

  // Leaf cost in units of SIMD triangle blocks: a block of up to `leaf_block` triangles costs
  // one test (the blocked SAH of Embree's builders).
  float blocks(uint32_t n) const {
    const uint32_t b = uint32_t(std::max(options_.leaf_block, 1));
    return float((n + b - 1) / b);
  }

  static int binOf(float c, float lo, float scale, int bins) {
    const int b = int((c - lo) * scale);
    return std::clamp(b, 0, bins - 1);
  }

  std::vector<BuildRef>& refs_;
  const BvhBuildOptions& options_;
  std::vector<BvhNode>& nodes_;
  std::atomic<uint32_t> next_node_{1};
};

int depthOf(const std::vector<BvhNode>& nodes, uint32_t i) {
  if (nodes[i].isLeaf()) return 1;
  return 1 + std::max(depthOf(nodes, nodes[i].index), depthOf(nodes, nodes[i].index + 1));
}

}  // namespace

int Bvh::depth() const {
  return nodes.empty() ? 0 : depthOf(nodes, 0);
}

float Bvh::sahCost(const BvhBuildOptions& options) const {
  if (nodes.empty()) return 0.0f;
  const float root_area = Bounds3{nodes[0].lo, nodes[0].hi}.area();
  if (!(root_area > 0.0f)) return 0.0f;
  double cost = 0.0;
  for (const BvhNode& n : nodes) {
    const double rel = Bounds3{n.lo, n.hi}.area() / root_area;
    const int block = std::max(options.leaf_block, 1);
    cost += n.isLeaf()
                ? rel * options.intersection_cost * double((int(n.count) + block - 1) / block)
                : rel * options.traversal_cost;
  }
  return float(cost);
}

Bvh buildBvh(std::span<const glm::vec3> positions, std::span<const glm::uvec3> triangles,
             const BvhBuildOptions& options) {
  Bvh bvh;
  const size_t n = triangles.size();
  if (n == 0) return bvh;
  PENUMBRA_CHECK_MSG(n < (size_t(1) << 31), "{} triangles", n);
  std::vector<BuildRef> refs(n);
  parallelRange(n, 4096, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const glm::uvec3 t = triangles[i];
      BuildRef& r = refs[i];
      r.bounds = Bounds3();
      r.bounds.extend(positions[t.x]);
      r.bounds.extend(positions[t.y]);
      r.bounds.extend(positions[t.z]);
      r.centroid = r.bounds.center();
      r.triangle = uint32_t(i);
    }
  });
  bvh.nodes.resize(2 * n);  // a binary tree with n leaves at most has 2n - 1 nodes
  Builder builder(refs, options, bvh.nodes);
  builder.build(0, 0, uint32_t(n), 1);
  bvh.nodes.resize(builder.used());
  bvh.refs.resize(n);
  for (size_t i = 0; i < n; ++i) bvh.refs[i] = refs[i].triangle;
  return bvh;
}

}  // namespace penumbra
