// The ray cache of the Ray Engine (Carr, Hall, Hart 2002, sec. 5.3): a 5-D ray tree that
// collects rays into buckets of coherent origins and directions, so that a back end (the GPU
// kernel of sec. 4, a SIMD packet tracer) intersects groups of similar rays together.
//
// The 5-D ray space (after Arvo and Kirk 1987, the paper's ref. 1) is the origin (x, y, z)
// plus the unit direction in the octahedral parameterisation (u, v) in [-1, 1]^2 (see
// octahedralDirection in ray_cache.cpp). Arvo and Kirk used the direction cube: six faces,
// each with its own (u, v) chart. One octahedral chart keeps direction space a single
// rectangle, so one variance test and one split value at the mean apply to it, and is
// continuous except along the folds of the lower hemisphere.
//
// The tree, as in sec. 5.3:
//  - rays are inserted one by one in a random (seeded) order, "which helps keep the tree
//    balanced": the first rays that reach a leaf are an unbiased sample of its region;
//  - a leaf that grows beyond bucket_size rays is split at the mean of its rays along the
//    dimension of greatest variance. Origins are in scene units and directions are
//    unitless, so raw variances are not comparable; each dimension's variance is divided
//    by the square of the extent of that dimension over all rays inserted so far (the
//    bounding box of the batches), which makes the test unit-free and scale-invariant: a
//    node is split where its rays cover the largest fraction of the batch's spread. (The
//    paper says "four subnodes"; a single axis and a single split value make two sides, so
//    this is a binary tree, and two of its levels make the paper's four subnodes.) A leaf
//    whose rays are all identical in all five coordinates is never split and may hold more
//    than bucket_size rays;
//  - nextBucket() takes the fullest bucket found by greedy descent (each node counts the
//    rays below it; follow the larger child), all of it (at most bucket_size rays of an
//    over-full leaf). If that is short, it steals from the leaf's sibling the rays nearest to
//    the bucket's mean (5-D distance, normalised like the split test), walking further up
//    if needed. Internal nodes always hold more than bucket_size rays, so the sibling alone
//    always suffices, and since the greedy search took the larger child the sibling is a
//    leaf: a bucket is a leaf plus the nearest part of its neighbour. Finally every subtree
//    whose count fell to bucket_size or below is merged into a single leaf (typically just
//    the parent of the chosen leaf: the paper's "typically merged only a single level").
//    A split shares bucket_size + 1 rays between two leaves; in a 1M random-ray batch about
//    77% of each bucket comes from its own leaf (the paper: "typically only 50-80% full").
//
// Contract kept by nextBucket(): it returns exactly min(bucket_size, size()) rays, so every
// bucket is full except the last one of a drained cache (or the ones taken while fewer than
// bucket_size rays remained). Every inserted ray is returned exactly once.
//
// Cost: insertion is O(depth) per ray plus the splits, which move bucket_size + 1 rays each
// (about 1.4 moves per ray in total for random rays); nextBucket() is O(depth + bucket_size).
// 1M random rays with bucket_size 256 insert and drain in about 0.3 s on one core. Rays live in
// fixed-size chunks of a flat pool and nodes in a vector; nothing is allocated per ray. Not
// thread-safe.
#pragma once

#include "penumbra/core/rng.h"
#include "penumbra/kernels/ray.h"

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace penumbra {

class RayEngine;

struct RayCacheOptions {
  uint32_t bucket_size = 256;  // rays per bucket, > 0 (the paper's 256: two 64x4 textures)
  uint64_t seed = 0;           // seeds the random insertion order
};

// Counters and times for the benchmark table (the paper's Table 3 splits time between CPU
// ray organisation and intersection).
struct RayCacheStats {
  double insert_seconds = 0.0;  // insert(): parameterising, shuffling, descending, splitting
  double bucket_seconds = 0.0;  // nextBucket(): greedy search, stealing, merging
  double trace_seconds = 0.0;   // traceThroughCache() only: time inside the engine
  uint64_t rays = 0;            // rays inserted
  uint64_t buckets = 0;         // buckets returned
  uint64_t splits = 0;          // leaves split in two
  uint64_t merges = 0;          // subtrees collapsed into one leaf after a bucket left
  uint64_t steals = 0;          // buckets that needed rays from outside their leaf
  uint64_t stolen_rays = 0;     // rays taken from outside the chosen leaf
  uint64_t peak_nodes = 0;      // largest number of tree nodes at any time
  uint32_t max_depth = 0;       // deepest leaf reached by an insertion (root = 0)
};

class RayCache {
 public:
  // Contract: options.bucket_size > 0.
  explicit RayCache(const RayCacheOptions& options = {});

  // Adds every ray of `rays`, in a random order drawn from the cache's seeded generator.
  // Rays are identified by consecutive ids: the returned id is that of rays[0], and rays[i]
  // has id first + i; the first batch starts at 0, each later batch continues the numbering
  // (so with a single batch the ids are input indices). Non-finite coordinates and zero
  // directions are accepted (they only affect grouping: such coordinates count as 0).
  // Contract: fewer than 2^32 rays in total over the cache's life.
  uint32_t insert(const RayBatch& rays);
  // Adds rays[subset[k]] for every k, numbered like insert(): subset[k] gets id first + k. For
  // callers that collect a few rays of a larger batch (the CPU/GPU split's per-cell caches,
  // hybrid.h) without copying them out. Contract: every subset[k] < rays.size().
  uint32_t insert(const RayBatch& rays, std::span<const uint32_t> subset);

  bool empty() const { return size() == 0; }
  size_t size() const;  // rays inserted and not yet returned
  uint32_t bucketSize() const { return bucket_size_; }

  // Removes and returns the next coherent bucket: exactly min(bucket_size, size()) ray ids
  // (empty when the cache is empty). The second form reuses `out`'s storage.
  std::vector<uint32_t> nextBucket();
  void nextBucket(std::vector<uint32_t>& out);

  const RayCacheStats& stats() const { return stats_; }
  size_t nodeCount() const { return nodes_.size() - 2 * free_pairs_.size(); }
  size_t leafCount() const;

  // Checks the tree's invariants (counts add up, parent links, every ray on the right side
  // of every split above it, internal nodes hold more than bucket_size rays, non-root leaves
  // are non-empty, over-full leaves hold identical rays). Returns "" or what is wrong.
  // O(size * depth); for tests.
  std::string checkInvariants() const;

 private:
  // One ray in the cache: its 5-D coordinates and its id (24 bytes).
  struct Entry {
    float c[5];
    uint32_t id;
  };
  struct Node {
    uint32_t count = 0;       // rays in this subtree
    uint32_t parent = kNone;  // kNone for the root
    uint32_t child = kNone;   // left child; the right one is child + 1; kNone for a leaf
    uint32_t chunk = kNone;   // leaf: head of its chunk list (kNone when empty)
    float split = 0.0f;       // internal: left holds c[axis] < split, right the rest
    uint32_t stamp = 0;       // nextBucket() epoch that last removed rays below this node
    uint8_t axis = 0;
    bool identical = false;  // leaf: all its rays have equal coordinates (never split)
  };
  static constexpr uint32_t kNone = 0xffffffffu;

  bool isLeaf(uint32_t n) const { return nodes_[n].child == kNone; }
  uint32_t allocPair();
  uint32_t allocChunk();
  void pushEntry(uint32_t leaf, const Entry& e);
  Entry popEntry(uint32_t leaf);
  void gatherLeaf(uint32_t leaf, std::vector<Entry>& out);
  uint32_t insertRays(const RayBatch& rays, const uint32_t* subset, size_t n);
  void insertOne(const Entry& e);
  void splitLeaf(uint32_t leaf);
  void freeChunks(uint32_t head);
  void takeFromLeaf(uint32_t leaf, uint32_t k, std::vector<uint32_t>& out, double* sum);
  void takeNearest(uint32_t leaf, uint32_t k, const double mean[5], std::vector<uint32_t>& out);
  uint32_t steal(uint32_t subtree, uint32_t need, const double mean[5], std::vector<uint32_t>& out);
  void fixup();
  void collapse(uint32_t n);
  void freeSubtree(uint32_t n);
  void noteNodes();

  uint32_t bucket_size_;
  uint32_t chunk_capacity_;  // entries per chunk: min(bucket_size, 64)
  Rng rng_;                  // draws the insertion order
  uint64_t next_id_ = 0;     // id of the next ray inserted
  uint32_t epoch_ = 0;       // counts nextBucket() calls; marks the nodes a call touched
  float lo_[5], hi_[5];      // bounding box of every ray inserted so far, per dimension

  std::vector<Node> nodes_;  // nodes_[0] is the root
  std::vector<uint32_t> free_pairs_;
  std::vector<Entry> pool_;  // chunk k holds pool_[k * chunk_capacity_ ...]
  std::vector<uint32_t> chunk_next_, chunk_fill_;
  uint32_t free_chunk_ = kNone;  // free chunks, linked through chunk_next_

  // Scratch buffers, kept to avoid allocation in steady state.
  std::vector<Entry> batch_, gather_;
  std::vector<uint32_t> stack_, aux_stack_;

  RayCacheStats stats_;
};

// Traces `rays` through a RayCache with `engine`: the rays are inserted, drained bucket by
// bucket, laid out in bucket order, intersected in one engine batch (whose parallel ranges
// then cover runs of coherent buckets), and the hits scattered back: hits[i] answers rays[i],
// identical to engine.intersect(rays.get(i)). `hits` is resized. Contract as RayCache.
// The scalar CPU back end traces one ray at a time and gains little or nothing from bucket
// order (measured on the bunny: random rays were not faster, camera rays in scanline order
// were faster than in buckets); the buckets are meant for packet and GPU back ends.
void traceThroughCache(const RayEngine& engine, const RayBatch& rays, HitBatch& hits,
                       const RayCacheOptions& options, RayCacheStats* stats = nullptr);

}  // namespace penumbra
