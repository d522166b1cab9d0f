// The ray cache: a 5-D ray tree (Carr, Hall, Hart 2002, sec. 5.3). See ray_cache.h for the
// rules; this file cites the paper's sentences where it implements them.
#include "penumbra/raytrace/ray_cache.h"

#include "penumbra/core/check.h"
#include "penumbra/core/timer.h"
#include "penumbra/raytrace/ray_engine.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace penumbra {
namespace {

constexpr uint32_t kMaxChunk = 64;  // entries per chunk (1.5 KiB) when buckets are larger

float finiteOrZero(float x) {
  return std::isfinite(x) ? x : 0.0f;
}

// The octahedral parameterisation of a direction (Praun and Hoppe 2003; Cigolle et al. 2014):
// project onto the octahedron |x| + |y| + |z| = 1 and unfold the lower half onto the corners
// of the square, giving (u, v) in [-1, 1]^2. The map is continuous over the upper hemisphere
// and across the equator; its only seams are the folds of the lower hemisphere (the square's
// border). `d` need not be unit length; a zero or non-finite direction maps to (0, 0).
void octahedralDirection(float dx, float dy, float dz, float& u, float& v) {
  const float l1 = std::fabs(dx) + std::fabs(dy) + std::fabs(dz);
  if (!(l1 > 0.0f) || !std::isfinite(l1)) {
    u = v = 0.0f;
    return;
  }
  const float x = dx / l1, y = dy / l1;
  if (dz >= 0.0f) {
    u = x, v = y;
  } else {
    u = (1.0f - std::fabs(y)) * (x >= 0.0f ? 1.0f : -1.0f);
    v = (1.0f - std::fabs(x)) * (y >= 0.0f ? 1.0f : -1.0f);
  }
}

}  // namespace

RayCache::RayCache(const RayCacheOptions& options)
    : bucket_size_(options.bucket_size),
      chunk_capacity_(std::min(options.bucket_size, kMaxChunk)),
      rng_(options.seed, 0x5eed0ca5e) {
  PENUMBRA_CHECK_MSG(options.bucket_size > 0, "bucket_size {}", options.bucket_size);
  for (int d = 0; d < 5; ++d) lo_[d] = hi_[d] = 0.0f;
  nodes_.emplace_back();  // the root: an empty leaf
  noteNodes();
}

size_t RayCache::size() const {
  return nodes_[0].count;
}

void RayCache::noteNodes() {
  stats_.peak_nodes = std::max<uint64_t>(stats_.peak_nodes, nodeCount());
}

// ---------------------------------------------------------------------------------------------
// Storage: each leaf owns a singly linked stack of chunks. Rays are pushed into and popped from
// the head chunk; every chunk but the head is full, the head holds 1..chunk_capacity_ rays.

uint32_t RayCache::allocPair() {
  uint32_t p;
  if (!free_pairs_.empty()) {
    p = free_pairs_.back();
    free_pairs_.pop_back();
    nodes_[p] = Node{};
    nodes_[p + 1] = Node{};
  } else {
    p = uint32_t(nodes_.size());
    nodes_.resize(nodes_.size() + 2);
  }
  noteNodes();
  return p;
}

uint32_t RayCache::allocChunk() {
  uint32_t k = free_chunk_;
  if (k != kNone) {
    free_chunk_ = chunk_next_[k];
  } else {
    k = uint32_t(chunk_next_.size());
    chunk_next_.push_back(kNone);
    chunk_fill_.push_back(0);
    pool_.resize(pool_.size() + chunk_capacity_);
  }
  chunk_next_[k] = kNone;
  chunk_fill_[k] = 0;
  return k;
}

void RayCache::freeChunks(uint32_t head) {
  while (head != kNone) {
    const uint32_t next = chunk_next_[head];
    chunk_next_[head] = free_chunk_;
    free_chunk_ = head;
    head = next;
  }
}

void RayCache::pushEntry(uint32_t leaf, const Entry& e) {
  uint32_t k = nodes_[leaf].chunk;
  if (k == kNone || chunk_fill_[k] == chunk_capacity_) {
    const uint32_t fresh = allocChunk();
    chunk_next_[fresh] = k;
    nodes_[leaf].chunk = fresh;
    k = fresh;
  }
  pool_[size_t(k) * chunk_capacity_ + chunk_fill_[k]++] = e;
}

RayCache::Entry RayCache::popEntry(uint32_t leaf) {
  const uint32_t k = nodes_[leaf].chunk;
  const Entry e = pool_[size_t(k) * chunk_capacity_ + --chunk_fill_[k]];
  if (chunk_fill_[k] == 0) {
    nodes_[leaf].chunk = chunk_next_[k];
    chunk_next_[k] = free_chunk_;
    free_chunk_ = k;
  }
  return e;
}

// Appends the leaf's rays to `out` and releases its chunks (the count is left to the caller).
void RayCache::gatherLeaf(uint32_t leaf, std::vector<Entry>& out) {
  for (uint32_t k = nodes_[leaf].chunk; k != kNone; k = chunk_next_[k]) {
    const Entry* first = &pool_[size_t(k) * chunk_capacity_];
    out.insert(out.end(), first, first + chunk_fill_[k]);
  }
  freeChunks(nodes_[leaf].chunk);
  nodes_[leaf].chunk = kNone;
}

// ---------------------------------------------------------------------------------------------
// Insertion (sec. 5.3: "As rays are generated, they are added to the cache, which collects
// them into buckets of rays with coherent origins and directions.")

uint32_t RayCache::insert(const RayBatch& rays) {
  return insertRays(rays, nullptr, rays.size());
}

uint32_t RayCache::insert(const RayBatch& rays, std::span<const uint32_t> subset) {
  return insertRays(rays, subset.data(), subset.size());
}

// Inserts rays[subset[i]] (rays[i] when `subset` is null) for i < n.
uint32_t RayCache::insertRays(const RayBatch& rays, const uint32_t* subset, size_t n) {
  const Timer timer;
  PENUMBRA_CHECK_MSG(next_id_ + n <= 0xffffffffull, "{} rays already inserted, {} more", next_id_,
                     n);
  const uint32_t first = uint32_t(next_id_);
  if (n == 0) return first;

  // Room for the new rays in leaves that are on average half full or more, so that the pool
  // does not move while it grows.
  const size_t want_chunks = 2 * (size() + n) / chunk_capacity_ + 1;
  if (chunk_next_.capacity() < want_chunks) {
    pool_.reserve(want_chunks * chunk_capacity_);
    chunk_next_.reserve(want_chunks);
    chunk_fill_.reserve(want_chunks);
  }

  // Parameterise in input order (sequential reads of the batch), growing the bounding box
  // that normalises the variance test.
  batch_.resize(n);
  bool first_box = stats_.rays == 0;  // the box starts at the first ray ever inserted
  for (size_t i = 0; i < n; ++i) {
    const size_t j = subset ? size_t(subset[i]) : i;
    PENUMBRA_CHECK_MSG(j < rays.size(), "subset[{}] = {} of {} rays", i, j, rays.size());
    Entry& e = batch_[i];
    e.c[0] = finiteOrZero(rays.ox[j]);
    e.c[1] = finiteOrZero(rays.oy[j]);
    e.c[2] = finiteOrZero(rays.oz[j]);
    octahedralDirection(rays.dx[j], rays.dy[j], rays.dz[j], e.c[3], e.c[4]);
    e.id = first + uint32_t(i);
    if (first_box) {
      for (int d = 0; d < 5; ++d) lo_[d] = hi_[d] = e.c[d];
      first_box = false;
    }
    for (int d = 0; d < 5; ++d) {
      lo_[d] = std::min(lo_[d], e.c[d]);
      hi_[d] = std::max(hi_[d], e.c[d]);
    }
  }

  // "We also add rays to the cache in random order which helps keep the tree balanced":
  // a Fisher-Yates shuffle from the cache's seeded generator.
  for (size_t i = n; i > 1; --i) std::swap(batch_[i - 1], batch_[rng_.uniformInt(uint32_t(i))]);
  for (const Entry& e : batch_) insertOne(e);

  next_id_ += n;
  stats_.rays += n;
  stats_.insert_seconds += timer.seconds();
  return first;
}

void RayCache::insertOne(const Entry& e) {
  uint32_t n = 0, depth = 0;
  while (!isLeaf(n)) {
    Node& node = nodes_[n];
    ++node.count;
    n = node.child + (e.c[node.axis] < node.split ? 0u : 1u);
    ++depth;
  }
  stats_.max_depth = std::max(stats_.max_depth, depth);
  // A leaf of identical rays cannot be split; it stays marked while newcomers are identical
  // too. Compare with one of its rays before the newcomer joins (it may open a new chunk and
  // become the head chunk's first ray).
  Node& leaf = nodes_[n];
  if (leaf.identical && leaf.chunk != kNone &&
      !std::equal(e.c, e.c + 5, pool_[size_t(leaf.chunk) * chunk_capacity_].c)) {
    leaf.identical = false;
  }
  ++leaf.count;
  pushEntry(n, e);
  // "If adding a ray makes a bucket larger than the optimal bucket size then the node is
  // split".
  if (nodes_[n].count > bucket_size_ && !nodes_[n].identical) splitLeaf(n);
}

// Splits an over-full leaf "along the axis of greatest variance ... using the mean values of
// the ray origins and directions" (sec. 5.3), and its children again while they are over-full.
// Variances are divided by the squared extent of the batch in each dimension (ray_cache.h).
// Only dimensions where the rays differ are candidates; when rounding puts the mean at or
// outside the rays' range, the split value becomes the maximum (left: c < max, never empty).
// A leaf whose rays agree in every dimension is marked identical and left over-full.
void RayCache::splitLeaf(uint32_t leaf) {
  stack_.clear();
  stack_.push_back(leaf);
  while (!stack_.empty()) {
    const uint32_t n = stack_.back();
    stack_.pop_back();
    gather_.clear();
    gatherLeaf(n, gather_);
    const size_t m = gather_.size();

    double mean[5] = {0, 0, 0, 0, 0};
    float mn[5], mx[5];
    for (int d = 0; d < 5; ++d) mn[d] = mx[d] = gather_[0].c[d];
    for (const Entry& e : gather_) {
      for (int d = 0; d < 5; ++d) {
        mean[d] += e.c[d];
        mn[d] = std::min(mn[d], e.c[d]);
        mx[d] = std::max(mx[d], e.c[d]);
      }
    }
    for (double& x : mean) x /= double(m);
    double var[5] = {0, 0, 0, 0, 0};
    for (const Entry& e : gather_) {
      for (int d = 0; d < 5; ++d) var[d] += (e.c[d] - mean[d]) * (e.c[d] - mean[d]);
    }
    int axis = -1;
    double best = -1.0;
    for (int d = 0; d < 5; ++d) {
      if (!(mx[d] > mn[d])) continue;
      const double extent = double(hi_[d]) - double(lo_[d]);  // >= mx - mn > 0
      const double score = var[d] / (extent * extent);
      if (score > best) best = score, axis = d;
    }
    if (axis < 0) {
      nodes_[n].identical = true;
      for (const Entry& e : gather_) pushEntry(n, e);
      continue;
    }

    float split = float(mean[axis]);
    if (!(split > mn[axis] && split <= mx[axis])) split = mx[axis];
    const uint32_t pair = allocPair();
    for (uint32_t k = 0; k < 2; ++k) nodes_[pair + k].parent = n;
    for (const Entry& e : gather_) {
      const uint32_t c = pair + (e.c[axis] < split ? 0u : 1u);
      ++nodes_[c].count;
      pushEntry(c, e);
    }
    Node& node = nodes_[n];
    node.child = pair;
    node.axis = uint8_t(axis);
    node.split = split;
    node.identical = false;
    ++stats_.splits;
    for (uint32_t k = 0; k < 2; ++k) {
      if (nodes_[pair + k].count > bucket_size_) stack_.push_back(pair + k);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Taking buckets

void RayCache::takeFromLeaf(uint32_t leaf, uint32_t k, std::vector<uint32_t>& out, double* sum) {
  for (uint32_t i = 0; i < k; ++i) {
    const Entry e = popEntry(leaf);
    out.push_back(e.id);
    if (sum) {
      for (int d = 0; d < 5; ++d) sum[d] += e.c[d];
    }
  }
  nodes_[leaf].count -= k;
}

std::vector<uint32_t> RayCache::nextBucket() {
  std::vector<uint32_t> out;
  nextBucket(out);
  return out;
}

void RayCache::nextBucket(std::vector<uint32_t>& out) {
  out.clear();
  if (nodes_[0].count == 0) return;
  const Timer timer;
  ++epoch_;

  // "Our search traverses down the largest valued nodes until a bucket is reached."
  uint32_t n = 0;
  while (!isLeaf(n)) {
    nodes_[n].stamp = epoch_;
    const uint32_t c = nodes_[n].child;
    n = nodes_[c + 1].count > nodes_[c].count ? c + 1 : c;
  }
  nodes_[n].stamp = epoch_;
  const uint32_t own = std::min(nodes_[n].count, bucket_size_);
  PENUMBRA_CHECK(own > 0);  // non-root leaves are never empty (checkInvariants)
  out.reserve(bucket_size_);
  double mean[5] = {0, 0, 0, 0, 0};
  takeFromLeaf(n, own, out, mean);
  for (double& x : mean) x /= double(own);

  // "Once the search has chosen a bucket, rays are stolen from that node's siblings to fill
  // the bucket": the sibling subtree at each level on the way up, so the nearest rays in the
  // tree come first. Walking up to the root makes every bucket full while rays remain.
  uint32_t removed = own;  // rays removed below x
  for (uint32_t x = n; x != 0;) {
    const uint32_t p = nodes_[x].parent;
    if (out.size() < bucket_size_) {
      const uint32_t c = nodes_[p].child;
      const uint32_t sibling = x == c ? c + 1 : c;
      removed += steal(sibling, bucket_size_ - uint32_t(out.size()), mean, out);
    }
    nodes_[p].count -= removed;
    x = p;
  }
  if (out.size() > own) {
    ++stats_.steals;
    stats_.stolen_rays += out.size() - own;
  }

  fixup();
  ++stats_.buckets;
  stats_.bucket_seconds += timer.seconds();
}

// Takes up to `need` rays from the subtree at `subtree` (depth first) and keeps the subtree's
// counts, not its ancestors', up to date. Returns the number taken. From a leaf that has more
// than needed it takes the rays nearest to the bucket's mean (5-D distance, each dimension
// divided by the batch's extent as in the split test).
//
// Under the tree's invariants this is simpler than it looks: the chosen leaf's parent holds
// more than bucket_size rays, so its sibling alone can fill the bucket; and the greedy search
// took the larger child, so that sibling is a leaf. The general walk stays for robustness.
uint32_t RayCache::steal(uint32_t subtree, uint32_t need, const double mean[5],
                         std::vector<uint32_t>& out) {
  uint32_t got = 0;
  stack_.clear();
  stack_.push_back(subtree);
  while (!stack_.empty() && got < need) {
    const uint32_t n = stack_.back();
    stack_.pop_back();
    Node& node = nodes_[n];
    if (node.count == 0) continue;
    node.stamp = epoch_;
    if (node.child != kNone) {
      stack_.push_back(node.child + 1);
      stack_.push_back(node.child);
      continue;
    }
    const uint32_t k = std::min(node.count, need - got);
    if (k == node.count) {
      takeFromLeaf(n, k, out, nullptr);
    } else {
      takeNearest(n, k, mean, out);
    }
    got += k;
    for (uint32_t a = n; a != subtree;) {
      a = nodes_[a].parent;
      nodes_[a].count -= k;
    }
  }
  return got;
}

void RayCache::takeNearest(uint32_t leaf, uint32_t k, const double mean[5],
                           std::vector<uint32_t>& out) {
  double weight[5];
  for (int d = 0; d < 5; ++d) {
    const double extent = double(hi_[d]) - double(lo_[d]);
    weight[d] = extent > 0.0 ? 1.0 / (extent * extent) : 0.0;
  }
  auto distance2 = [&](const Entry& e) {
    double sum = 0.0;
    for (int d = 0; d < 5; ++d) sum += weight[d] * (e.c[d] - mean[d]) * (e.c[d] - mean[d]);
    return sum;
  };
  gather_.clear();
  gatherLeaf(leaf, gather_);
  std::nth_element(gather_.begin(), gather_.begin() + k, gather_.end(),
                   [&](const Entry& a, const Entry& b) { return distance2(a) < distance2(b); });
  for (uint32_t i = 0; i < k; ++i) out.push_back(gather_[i].id);
  for (size_t i = k; i < gather_.size(); ++i) pushEntry(leaf, gather_[i]);
  nodes_[leaf].count -= k;
}

// After a bucket leaves: "Our algorithm walks back up the tree from the removed bucket leaf
// node, collecting subtrees into a single bucket leaf node if the number of rays in the subtree
// has fallen below a threshold." The threshold is bucket_size: a subtree that fits in one
// bucket becomes one leaf. Only nodes that lost rays (stamped with this epoch) can need it;
// they are visited top down, so the highest such subtree is collapsed once. A split node with
// one empty side is replaced by its other side. (With the rules of nextBucket() that cannot
// happen: the chosen leaf and its sibling leaf are merged as soon as one of them empties. The
// case is handled anyway so that the invariants hold whatever is removed.)
void RayCache::fixup() {
  stack_.clear();
  stack_.push_back(0);
  while (!stack_.empty()) {
    const uint32_t n = stack_.back();
    stack_.pop_back();
    if (isLeaf(n)) continue;
    if (nodes_[n].count <= bucket_size_) {
      collapse(n);
      continue;
    }
    const uint32_t c = nodes_[n].child;
    if (nodes_[c].count == 0 || nodes_[c + 1].count == 0) {
      const uint32_t keep = nodes_[c].count == 0 ? c + 1 : c;
      freeSubtree(keep == c ? c + 1 : c);
      const Node kept = nodes_[keep];
      Node& node = nodes_[n];
      node.child = kept.child;
      node.chunk = kept.chunk;
      node.split = kept.split;
      node.axis = kept.axis;
      node.identical = kept.identical;
      node.stamp = kept.stamp;
      if (kept.child != kNone) {
        nodes_[kept.child].parent = n;
        nodes_[kept.child + 1].parent = n;
      }
      free_pairs_.push_back(c);
      stack_.push_back(n);  // look at it again in its new shape
      continue;
    }
    for (uint32_t k = c; k < c + 2; ++k) {
      if (nodes_[k].stamp == epoch_) stack_.push_back(k);
    }
  }
}

// Turns the subtree at `n` into one leaf holding all its rays, releasing the nodes below.
void RayCache::collapse(uint32_t n) {
  gather_.clear();
  aux_stack_.clear();
  aux_stack_.push_back(n);
  while (!aux_stack_.empty()) {
    const uint32_t m = aux_stack_.back();
    aux_stack_.pop_back();
    if (isLeaf(m)) {
      gatherLeaf(m, gather_);
    } else {
      const uint32_t c = nodes_[m].child;
      aux_stack_.push_back(c);
      aux_stack_.push_back(c + 1);
      free_pairs_.push_back(c);  // not reused before this function returns
    }
  }
  PENUMBRA_CHECK_MSG(gather_.size() == nodes_[n].count, "{} rays, count {}", gather_.size(),
                     nodes_[n].count);
  Node& node = nodes_[n];
  node.child = kNone;
  node.identical = false;
  for (const Entry& e : gather_) pushEntry(n, e);
  ++stats_.merges;
}

// Releases everything below `n` and its chunks (the node `n` itself belongs to its pair).
void RayCache::freeSubtree(uint32_t n) {
  aux_stack_.clear();
  aux_stack_.push_back(n);
  while (!aux_stack_.empty()) {
    const uint32_t m = aux_stack_.back();
    aux_stack_.pop_back();
    if (isLeaf(m)) {
      freeChunks(nodes_[m].chunk);
      nodes_[m].chunk = kNone;
    } else {
      const uint32_t c = nodes_[m].child;
      aux_stack_.push_back(c);
      aux_stack_.push_back(c + 1);
      free_pairs_.push_back(c);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Diagnostics

size_t RayCache::leafCount() const {
  size_t leaves = 0;
  std::vector<uint32_t> stack{0};
  while (!stack.empty()) {
    const uint32_t n = stack.back();
    stack.pop_back();
    if (isLeaf(n)) {
      ++leaves;
    } else {
      stack.push_back(nodes_[n].child);
      stack.push_back(nodes_[n].child + 1);
    }
  }
  return leaves;
}

std::string RayCache::checkInvariants() const {
  std::vector<uint8_t> seen(next_id_, 0);
  size_t reachable = 0, rays = 0, chunks = 0;
  std::vector<uint32_t> stack{0};
  if (nodes_[0].parent != kNone) return "root has a parent";
  while (!stack.empty()) {
    const uint32_t n = stack.back();
    stack.pop_back();
    ++reachable;
    const Node& node = nodes_[n];
    if (node.child != kNone) {
      const Node &l = nodes_[node.child], &r = nodes_[node.child + 1];
      if (l.parent != n || r.parent != n) return fmt::format("node {}: bad parent links", n);
      if (l.count + r.count != node.count) return fmt::format("node {}: counts don't add up", n);
      if (node.count <= bucket_size_)
        return fmt::format("node {}: internal, {} rays", n, node.count);
      if (node.chunk != kNone) return fmt::format("node {}: internal with rays", n);
      stack.push_back(node.child);
      stack.push_back(node.child + 1);
      continue;
    }
    if (n != 0 && node.count == 0) return fmt::format("leaf {}: empty", n);
    uint32_t in_leaf = 0;
    const Entry* first = nullptr;
    for (uint32_t k = node.chunk; k != kNone; k = chunk_next_[k]) {
      ++chunks;
      const uint32_t fill = chunk_fill_[k];
      if (fill == 0 || fill > chunk_capacity_ || (k != node.chunk && fill != chunk_capacity_)) {
        return fmt::format("leaf {}: chunk {} holds {}", n, k, fill);
      }
      for (uint32_t i = 0; i < fill; ++i) {
        const Entry& e = pool_[size_t(k) * chunk_capacity_ + i];
        if (!first) first = &e;
        if (e.id >= next_id_ || seen[e.id]) return fmt::format("ray {}: bad or repeated", e.id);
        seen[e.id] = 1;
        if (node.identical && !std::equal(e.c, e.c + 5, first->c)) {
          return fmt::format("leaf {}: marked identical, rays differ", n);
        }
        // On the right side of every split above.
        for (uint32_t a = n; a != 0;) {
          const uint32_t p = nodes_[a].parent;
          const bool left = e.c[nodes_[p].axis] < nodes_[p].split;
          if (left != (a == nodes_[p].child)) {
            return fmt::format("ray {} in leaf {}: wrong side of node {}", e.id, n, p);
          }
          a = p;
        }
        ++in_leaf;
      }
    }
    if (in_leaf != node.count)
      return fmt::format("leaf {}: {} rays, count {}", n, in_leaf, node.count);
    if (node.count > bucket_size_ && !node.identical) {
      return fmt::format("leaf {}: {} rays and not identical", n, node.count);
    }
    rays += in_leaf;
  }
  if (reachable != nodeCount())
    return fmt::format("{} nodes reachable of {}", reachable, nodeCount());
  if (rays != size()) return fmt::format("{} rays in leaves, size {}", rays, size());
  size_t free_chunks = 0;
  for (uint32_t k = free_chunk_; k != kNone; k = chunk_next_[k]) ++free_chunks;
  if (chunks + free_chunks != chunk_next_.size()) {
    return fmt::format("{} chunks used + {} free != {}", chunks, free_chunks, chunk_next_.size());
  }
  return "";
}

// ---------------------------------------------------------------------------------------------

void traceThroughCache(const RayEngine& engine, const RayBatch& rays, HitBatch& hits,
                       const RayCacheOptions& options, RayCacheStats* stats) {
  const size_t n = rays.size();
  RayCache cache(options);
  cache.insert(rays);
  std::vector<uint32_t> order, bucket;
  order.reserve(n);
  while (!cache.empty()) {
    cache.nextBucket(bucket);
    order.insert(order.end(), bucket.begin(), bucket.end());
  }
  PENUMBRA_CHECK(order.size() == n);

  // Lay the rays out bucket after bucket, trace, and scatter the hits back to input order.
  RayBatch sorted;
  sorted.resize(n);
  LargeVector<float> RayBatch::*const fields[] = {&RayBatch::ox,   &RayBatch::oy,  &RayBatch::oz,
                                                  &RayBatch::tmin, &RayBatch::dx,  &RayBatch::dy,
                                                  &RayBatch::dz,   &RayBatch::tmax};
  for (const auto field : fields) {
    const LargeVector<float>& src = rays.*field;
    LargeVector<float>& dst = sorted.*field;
    for (size_t i = 0; i < n; ++i) dst[i] = src[order[i]];
  }
  HitBatch sorted_hits;
  const Timer timer;
  engine.intersect(sorted, sorted_hits);
  const double trace_seconds = timer.seconds();
  hits.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const uint32_t j = order[i];
    hits.triangle[j] = sorted_hits.triangle[i];
    hits.t[j] = sorted_hits.t[i];
    hits.u[j] = sorted_hits.u[i];
    hits.v[j] = sorted_hits.v[i];
  }
  if (stats) {
    *stats = cache.stats();
    stats->trace_seconds = trace_seconds;
  }
}

}  // namespace penumbra
