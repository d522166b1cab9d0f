// The ray cache (Carr, Hall, Hart 2002, sec. 5.3): every ray comes back exactly once, buckets
// hold exactly min(bucket_size, rays left) rays, the tree keeps its invariants through inserts
// and removals, tracing through the cache changes no hit, and buckets are coherent.
#include "penumbra/raytrace/ray_cache.h"

#include "penumbra/core/rng.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/raytrace/ray_engine.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace penumbra {
namespace {

using test::expectInternalError;
using test::randomDirection;
using test::randomInBox;

constexpr uint32_t kBucketSizes[] = {1, 2, 7, 64, 256, 1000, 1024};

enum class Kind { kFan, kRandom, kClusters, kIdentical, kMixed, kDegenerate };

const char* kindName(Kind k) {
  switch (k) {
    case Kind::kFan:
      return "fan";
    case Kind::kRandom:
      return "random";
    case Kind::kClusters:
      return "clusters";
    case Kind::kIdentical:
      return "identical";
    case Kind::kMixed:
      return "mixed";
    case Kind::kDegenerate:
      return "degenerate";
  }
  return "?";
}

void append(RayBatch& batch, const Ray& r) {
  const size_t i = batch.size();
  batch.resize(i + 1);
  batch.set(i, r);
}

// A pinhole camera at `eye` looking at `target`: rays through the pixels of a w x h image.
void addFan(RayBatch& batch, size_t n, glm::vec3 eye, glm::vec3 target, float half_fov_tan) {
  const glm::vec3 forward = glm::normalize(target - eye);
  const glm::vec3 right = glm::normalize(glm::cross(forward, glm::vec3(0.0f, 1.0f, 0.1f)));
  const glm::vec3 up = glm::cross(right, forward);
  const size_t w = std::max<size_t>(1, size_t(std::sqrt(double(n))));
  for (size_t i = 0; i < n; ++i) {
    const float px = (float(i % w) + 0.5f) / float(w) * 2.0f - 1.0f;
    const float py = (float(i / w) + 0.5f) / float(w) * 2.0f - 1.0f;
    Ray r;
    r.origin = eye;
    r.dir = glm::normalize(forward + half_fov_tan * (px * right + py * up));
    append(batch, r);
  }
}

void addRandom(RayBatch& batch, size_t n, Rng& rng, float half_size) {
  for (size_t i = 0; i < n; ++i) {
    Ray r;
    r.origin = randomInBox(rng, -half_size, half_size);
    r.dir = randomDirection(rng);
    if (i % 5 == 1) r.tmin = 0.01f;
    if (i % 5 == 2) r.tmax = 0.7f;
    append(batch, r);
  }
}

// Eight tight clusters of nearly equal rays.
void addClusters(RayBatch& batch, size_t n, Rng& rng) {
  glm::vec3 o[8], d[8];
  for (int c = 0; c < 8; ++c) o[c] = randomInBox(rng, -1.0f, 1.0f), d[c] = randomDirection(rng);
  for (size_t i = 0; i < n; ++i) {
    const uint32_t c = rng.uniformInt(8);
    Ray r;
    r.origin = o[c] + randomInBox(rng, -0.01f, 0.01f);
    r.dir = glm::normalize(d[c] + randomInBox(rng, -0.01f, 0.01f));
    append(batch, r);
  }
}

void addIdentical(RayBatch& batch, size_t n) {
  Ray r;
  r.origin = glm::vec3(0.25f, -0.5f, 2.0f);
  r.dir = glm::normalize(glm::vec3(-0.2f, 0.1f, -1.0f));
  for (size_t i = 0; i < n; ++i) append(batch, r);
}

// Zero, non-finite, huge and tiny coordinates among ordinary rays: only grouping may suffer.
void addDegenerate(RayBatch& batch, size_t n, Rng& rng) {
  constexpr float kInf = std::numeric_limits<float>::infinity();
  constexpr float kNan = std::numeric_limits<float>::quiet_NaN();
  for (size_t i = 0; i < n; ++i) {
    Ray r;
    r.origin = randomInBox(rng, -1.0f, 1.0f);
    r.dir = randomDirection(rng);
    switch (i % 8) {
      case 0:
        r.dir = glm::vec3(0.0f);
        break;
      case 1:
        r.origin.x = kNan;
        break;
      case 2:
        r.dir.y = kInf;
        break;
      case 3:
        r.origin = glm::vec3(1e30f, -1e30f, 3e38f);
        break;
      case 4:
        r.origin *= 1e-40f;
        break;  // denormals
      case 5:
        r.dir = glm::vec3(0.0f, 0.0f, -1.0f);
        break;
      default:
        break;
    }
    append(batch, r);
  }
}

RayBatch makeRays(Kind kind, size_t n, uint64_t seed) {
  Rng rng(seed, 17);
  RayBatch b;
  switch (kind) {
    case Kind::kFan:
      addFan(b, n, {0.0f, 0.5f, 4.0f}, {0.0f, 0.0f, 0.0f}, 0.5f);
      break;
    case Kind::kRandom:
      addRandom(b, n, rng, 1.0f);
      break;
    case Kind::kClusters:
      addClusters(b, n, rng);
      break;
    case Kind::kIdentical:
      addIdentical(b, n);
      break;
    case Kind::kMixed:
      addFan(b, n / 4, {0.0f, 0.5f, 4.0f}, {0.0f, 0.0f, 0.0f}, 0.5f);
      addRandom(b, n / 4, rng, 1.0f);
      addClusters(b, n / 4, rng);
      addIdentical(b, n - b.size());
      break;
    case Kind::kDegenerate:
      addDegenerate(b, n, rng);
      break;
  }
  return b;
}

// Drains `cache`, checking after every bucket what nextBucket() promises: exactly
// min(bucket_size, size()) ids, each in [first, first + count) and never seen before; and the
// tree's invariants after the first buckets, at powers of two and at the end. Appends the
// buckets to `buckets` when given.
::testing::AssertionResult drainAndCheck(RayCache& cache, uint32_t first, size_t count,
                                         std::vector<std::vector<uint32_t>>* buckets = nullptr) {
  std::vector<uint8_t> seen(count, 0);
  size_t returned = 0, index = 0;
  std::vector<uint32_t> bucket;
  while (!cache.empty()) {
    const size_t before = cache.size();
    cache.nextBucket(bucket);
    const size_t expected = std::min<size_t>(cache.bucketSize(), before);
    if (bucket.size() != expected) {
      return ::testing::AssertionFailure()
             << "bucket " << index << " holds " << bucket.size() << " rays, expected " << expected;
    }
    if (cache.size() != before - bucket.size()) {
      return ::testing::AssertionFailure() << "size() did not drop by the bucket's size";
    }
    for (uint32_t id : bucket) {
      if (id < first || id - first >= count) {
        return ::testing::AssertionFailure() << "id " << id << " out of range";
      }
      if (seen[id - first]++) return ::testing::AssertionFailure() << "id " << id << " twice";
    }
    returned += bucket.size();
    if (index < 4 || std::has_single_bit(index) || cache.empty()) {
      const std::string problem = cache.checkInvariants();
      if (!problem.empty()) {
        return ::testing::AssertionFailure() << "after bucket " << index << ": " << problem;
      }
    }
    if (buckets) buckets->push_back(bucket);
    ++index;
  }
  if (returned != count) {
    return ::testing::AssertionFailure() << returned << " rays returned of " << count;
  }
  if (!cache.nextBucket().empty()) return ::testing::AssertionFailure() << "empty cache gave rays";
  if (cache.nodeCount() != 1) {
    return ::testing::AssertionFailure() << "drained tree keeps " << cache.nodeCount() << " nodes";
  }
  return ::testing::AssertionSuccess();
}

// --------------------------------------------------------------------------------------------

TEST(RayCache, EveryRayReturnedExactlyOnceInFullBuckets) {
  for (const Kind kind : {Kind::kFan, Kind::kRandom, Kind::kClusters, Kind::kIdentical,
                          Kind::kMixed, Kind::kDegenerate}) {
    const RayBatch rays = makeRays(kind, 3001, 42);
    for (const uint32_t bucket_size : kBucketSizes) {
      RayCache cache(RayCacheOptions{bucket_size, 9});
      EXPECT_EQ(cache.insert(rays), 0u);
      ASSERT_EQ(cache.size(), rays.size());
      const std::string problem = cache.checkInvariants();
      ASSERT_EQ(problem, "") << kindName(kind) << " bucket " << bucket_size;
      ASSERT_TRUE(drainAndCheck(cache, 0, rays.size()))
          << kindName(kind) << ", bucket size " << bucket_size;
      EXPECT_EQ(cache.stats().buckets, (rays.size() + bucket_size - 1) / bucket_size);
      EXPECT_EQ(cache.stats().rays, rays.size());
    }
  }
}

TEST(RayCache, LeavesAreSplitUntilTheyFitABucket) {
  // Right after insertion (no removals yet), no leaf of distinct rays exceeds the bucket
  // size: checkInvariants() verifies it; here also that the tree actually grew and that the
  // average leaf is at least a quarter full (random insertion order keeps splits balanced).
  const RayBatch rays = makeRays(Kind::kRandom, 20000, 3);
  for (const uint32_t bucket_size : {7u, 64u, 256u}) {
    RayCache cache(RayCacheOptions{bucket_size, 1});
    cache.insert(rays);
    ASSERT_EQ(cache.checkInvariants(), "");
    const size_t leaves = cache.leafCount();
    EXPECT_GE(leaves, rays.size() / bucket_size) << bucket_size;
    EXPECT_LE(leaves, 4 * rays.size() / bucket_size + 1) << bucket_size;
    EXPECT_EQ(cache.nodeCount(), 2 * leaves - 1);
    EXPECT_EQ(cache.stats().splits, leaves - 1);
    // A balanced binary tree over `leaves` leaves is about log2(leaves) deep.
    EXPECT_LE(cache.stats().max_depth, 3 * std::bit_width(leaves)) << bucket_size;
  }
}

TEST(RayCache, EmptyOneRayAndOversizedBuckets) {
  RayCache empty_cache(RayCacheOptions{4, 0});
  EXPECT_EQ(empty_cache.insert(RayBatch{}), 0u);
  EXPECT_TRUE(empty_cache.empty());
  EXPECT_TRUE(empty_cache.nextBucket().empty());
  EXPECT_EQ(empty_cache.checkInvariants(), "");

  for (const uint32_t bucket_size : kBucketSizes) {
    RayCache one(RayCacheOptions{bucket_size, 0});
    one.insert(makeRays(Kind::kRandom, 1, 5));
    EXPECT_EQ(one.nextBucket(), std::vector<uint32_t>{0});
    EXPECT_TRUE(one.empty());
  }

  // A bucket larger than the batch: one bucket with everything, and no split at all.
  const RayBatch rays = makeRays(Kind::kMixed, 999, 8);
  RayCache big(RayCacheOptions{1000, 0});
  big.insert(rays);
  EXPECT_EQ(big.nodeCount(), 1u);
  std::vector<uint32_t> all = big.nextBucket();
  std::sort(all.begin(), all.end());
  ASSERT_EQ(all.size(), rays.size());
  for (uint32_t i = 0; i < all.size(); ++i) ASSERT_EQ(all[i], i);
  EXPECT_TRUE(big.empty());
}

TEST(RayCache, IdenticalRaysAreNeverSplit) {
  const RayBatch rays = makeRays(Kind::kIdentical, 10000, 0);
  for (const uint32_t bucket_size : {1u, 7u, 256u}) {
    RayCache cache(RayCacheOptions{bucket_size, 0});
    cache.insert(rays);
    EXPECT_EQ(cache.nodeCount(), 1u);
    EXPECT_EQ(cache.stats().splits, 0u);
    EXPECT_EQ(cache.checkInvariants(), "");
    ASSERT_TRUE(drainAndCheck(cache, 0, rays.size())) << bucket_size;
  }
  // Identical rays inside a spread batch end up in one over-full leaf, and the rest is split.
  RayBatch half = makeRays(Kind::kRandom, 5000, 1);
  const RayBatch same = makeRays(Kind::kIdentical, 5000, 0);
  for (size_t i = 0; i < same.size(); ++i) append(half, same.get(i));
  RayCache cache(RayCacheOptions{64, 3});
  cache.insert(half);
  EXPECT_EQ(cache.checkInvariants(), "");
  EXPECT_GT(cache.nodeCount(), 100u);
  EXPECT_LT(cache.stats().splits, 2 * half.size() / 64);
  ASSERT_TRUE(drainAndCheck(cache, 0, half.size()));
}

TEST(RayCache, AnIdenticalLeafNoticesADifferentNewcomer) {
  // 2 x 64 identical rays fill two chunks of a leaf that cannot be split; the next ray opens a
  // third chunk. If it differs, the leaf must split (and not count it as one more copy).
  RayCache cache(RayCacheOptions{64, 0});
  cache.insert(makeRays(Kind::kIdentical, 128, 0));
  EXPECT_EQ(cache.nodeCount(), 1u);
  cache.insert(makeRays(Kind::kRandom, 1, 3));
  EXPECT_EQ(cache.checkInvariants(), "");
  EXPECT_EQ(cache.nodeCount(), 3u);
  // And more copies go on growing the identical leaf, without splitting it.
  cache.insert(makeRays(Kind::kIdentical, 1000, 0));
  EXPECT_EQ(cache.checkInvariants(), "");
  EXPECT_EQ(cache.nodeCount(), 3u);
  ASSERT_TRUE(drainAndCheck(cache, 0, 1129));
}

TEST(RayCache, InterleavedInsertsAndBucketsKeepEveryRay) {
  // A ray tracer adds rays as it goes: batches keep numbering where the last one stopped.
  for (const uint32_t bucket_size : {1u, 7u, 64u, 256u}) {
    RayCache cache(RayCacheOptions{bucket_size, 77});
    std::vector<uint8_t> seen;
    size_t total = 0;
    const Kind kinds[] = {Kind::kRandom,     Kind::kFan,       Kind::kClusters,
                          Kind::kDegenerate, Kind::kIdentical, Kind::kMixed};
    for (int round = 0; round < 6; ++round) {
      const RayBatch rays = makeRays(kinds[round], 500 + 731 * round, round);
      ASSERT_EQ(cache.insert(rays), total);
      total += rays.size();
      seen.resize(total, 0);
      // Take about half of what is there.
      const size_t target = cache.size() / 2;
      while (cache.size() > target) {
        const size_t before = cache.size();
        const std::vector<uint32_t> bucket = cache.nextBucket();
        ASSERT_EQ(bucket.size(), std::min<size_t>(bucket_size, before));
        for (uint32_t id : bucket) {
          ASSERT_LT(id, total);
          ASSERT_EQ(seen[id]++, 0) << "id " << id;
        }
      }
      ASSERT_EQ(cache.checkInvariants(), "") << "round " << round << " bucket " << bucket_size;
    }
    while (!cache.empty()) {
      for (uint32_t id : cache.nextBucket()) ASSERT_EQ(seen[id]++, 0) << "id " << id;
    }
    for (size_t i = 0; i < total; ++i) ASSERT_EQ(seen[i], 1) << "id " << i;
    EXPECT_EQ(cache.nodeCount(), 1u);
    EXPECT_GT(cache.stats().merges, 0u);
  }
}

TEST(RayCache, DeterministicForAGivenSeed) {
  const RayBatch rays = makeRays(Kind::kMixed, 5000, 4);
  auto buckets = [&](uint64_t seed) {
    RayCache cache(RayCacheOptions{64, seed});
    cache.insert(rays);
    std::vector<std::vector<uint32_t>> out;
    EXPECT_TRUE(drainAndCheck(cache, 0, rays.size(), &out));
    return out;
  };
  EXPECT_EQ(buckets(1), buckets(1));
  // The seed is used: another insertion order gives another tree.
  EXPECT_NE(buckets(1), buckets(2));
}

// insert(rays, subset) (the CPU/GPU split's per-cell caches) is insert() of a batch holding
// rays[subset[k]] at position k: the same ids, tree and buckets, without copying the rays.
TEST(RayCache, SubsetInsertIsInsertOfTheGatheredRays) {
  const RayBatch rays = makeRays(Kind::kMixed, 6000, 9);
  Rng rng(5, 5);
  std::vector<uint32_t> subset;
  for (uint32_t i = 0; i < rays.size(); ++i) {
    if (rng.uniform() < 0.4f) subset.push_back(i);
  }
  for (size_t i = subset.size(); i > 1; --i)
    std::swap(subset[i - 1], subset[rng.uniformInt(uint32_t(i))]);
  const size_t half = subset.size() / 2;
  RayBatch gathered;
  gathered.resize(subset.size());
  for (size_t k = 0; k < subset.size(); ++k) gathered.set(k, rays.get(subset[k]));
  for (const uint32_t bucket_size : {1u, 16u, 256u}) {
    RayCache by_subset(RayCacheOptions{bucket_size, 3}), by_copy(RayCacheOptions{bucket_size, 3});
    // Two batches each, with buckets taken in between.
    ASSERT_EQ(by_subset.insert(rays, std::span(subset.data(), half)), 0u);
    RayBatch first_half;
    first_half.resize(half);
    for (size_t k = 0; k < half; ++k) first_half.set(k, gathered.get(k));
    ASSERT_EQ(by_copy.insert(first_half), 0u);
    for (int i = 0; i < 5; ++i) ASSERT_EQ(by_subset.nextBucket(), by_copy.nextBucket());
    RayBatch second_half;
    second_half.resize(subset.size() - half);
    for (size_t k = half; k < subset.size(); ++k) second_half.set(k - half, gathered.get(k));
    ASSERT_EQ(by_subset.insert(rays, std::span(subset.data() + half, subset.size() - half)),
              uint32_t(half));
    ASSERT_EQ(by_copy.insert(second_half), uint32_t(half));
    ASSERT_EQ(by_subset.checkInvariants(), "");
    while (!by_copy.empty()) ASSERT_EQ(by_subset.nextBucket(), by_copy.nextBucket());
    EXPECT_TRUE(by_subset.empty());
    // An empty subset inserts nothing and keeps the numbering.
    EXPECT_EQ(by_subset.insert(rays, std::span<const uint32_t>()), uint32_t(subset.size()));
    EXPECT_TRUE(by_subset.empty());
  }
}

TEST(RayCache, GreedySearchTakesTheLargerClusterFirstAndStealsNearby) {
  // Two clusters far apart in origin and direction: 3 buckets' worth and half a bucket. The
  // root split separates them; the greedy search goes to the larger side, and stealing fills
  // buckets from inside it, so no bucket mixes the clusters and the small one comes last.
  constexpr uint32_t kB = 64;
  for (const uint64_t seed : {1u, 2u, 3u, 4u}) {
    Rng rng(seed, 3);
    RayBatch rays;
    for (uint32_t i = 0; i < 3 * kB + kB / 2; ++i) {
      const bool big = i < 3 * kB;
      Ray r;
      r.origin = (big ? glm::vec3(-5.0f) : glm::vec3(5.0f)) + randomInBox(rng, -0.5f, 0.5f);
      r.dir = glm::normalize((big ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0)) +
                             randomInBox(rng, -0.3f, 0.3f));
      append(rays, r);
    }
    RayCache cache(RayCacheOptions{kB, seed});
    cache.insert(rays);
    std::vector<std::vector<uint32_t>> buckets;
    ASSERT_TRUE(drainAndCheck(cache, 0, rays.size(), &buckets));
    ASSERT_EQ(buckets.size(), 4u);
    for (int b = 0; b < 3; ++b) {
      for (uint32_t id : buckets[b]) EXPECT_LT(id, 3 * kB) << "seed " << seed << " bucket " << b;
    }
    for (uint32_t id : buckets[3]) EXPECT_GE(id, 3 * kB) << "seed " << seed;
    EXPECT_GT(cache.stats().steals, 0u);  // leaves are not full: buckets needed topping up
  }
}

TEST(RayCache, SplitsDoNotDependOnUnitsOrDirectionLength) {
  // The variance test divides each dimension by the batch's extent (ray_cache.h), so a scene
  // in millimetres or in kilometres gives the same tree: scaling origins by powers of two is
  // exact in floating point, so the buckets must be identical. Without the normalisation a
  // large scene would split only origins and a small one only directions. Direction length
  // does not matter either.
  const RayBatch rays = makeRays(Kind::kRandom, 20000, 13);
  auto buckets = [](const RayBatch& b) {
    RayCache cache(RayCacheOptions{64, 4});
    cache.insert(b);
    std::vector<std::vector<uint32_t>> out;
    while (!cache.empty()) out.push_back(cache.nextBucket());
    return out;
  };
  const std::vector<std::vector<uint32_t>> reference = buckets(rays);
  for (const float origin_scale : {1024.0f, 1.0f / 1024.0f}) {
    RayBatch scaled = rays;
    for (size_t i = 0; i < rays.size(); ++i) {
      scaled.ox[i] *= origin_scale, scaled.oy[i] *= origin_scale, scaled.oz[i] *= origin_scale;
      scaled.dx[i] *= 4.0f, scaled.dy[i] *= 4.0f, scaled.dz[i] *= 4.0f;
    }
    EXPECT_EQ(buckets(scaled), reference) << origin_scale;
  }
}

TEST(RayCache, StolenRaysAreTheNearestOnes) {
  // Parallel rays with origins on a line: only x varies, every node is an interval of x and a
  // leaf's sibling is the adjacent interval. A bucket is its leaf plus the sibling's rays
  // nearest to it, so it must be a contiguous run of the rays still in the cache: no ray left
  // behind lies between a bucket's smallest and largest x. Taking arbitrary rays from the
  // sibling breaks this.
  constexpr size_t kN = 4000;
  Rng rng(6, 6);
  std::vector<uint32_t> rank(kN);
  for (uint32_t i = 0; i < kN; ++i) rank[i] = i;
  for (size_t i = kN; i > 1; --i) std::swap(rank[i - 1], rank[rng.uniformInt(uint32_t(i))]);
  RayBatch rays;
  for (size_t i = 0; i < kN; ++i) {
    Ray r;
    r.origin = glm::vec3(float(rank[i]) / float(kN), 0.0f, 0.0f);
    append(rays, r);
  }
  for (const uint32_t bucket_size : {7u, 64u, 256u}) {
    RayCache cache(RayCacheOptions{bucket_size, 2});
    cache.insert(rays);
    std::vector<uint8_t> taken(kN, 0);
    while (!cache.empty()) {
      const std::vector<uint32_t> bucket = cache.nextBucket();
      uint32_t lo = kN, hi = 0;
      for (uint32_t id : bucket)
        lo = std::min(lo, rank[id]), hi = std::max(hi, rank[id]), taken[id] = 1;
      size_t between = 0;
      for (size_t i = 0; i < kN; ++i) between += !taken[i] && rank[i] > lo && rank[i] < hi;
      ASSERT_EQ(between, 0u) << "bucket size " << bucket_size << ", x in [" << lo << ", " << hi
                             << "]";
    }
    EXPECT_GT(cache.stats().steals, 0u);
  }
}

// --------------------------------------------------------------------------------------------
// Coherence: the mean angle between two rays of the same bucket, and the mean distance
// between their origins, against the same over random pairs of the whole batch.

struct Spread {
  double angle = 0.0;     // radians
  double distance = 0.0;  // between origins
};

Spread pairSpread(const RayBatch& rays, const std::vector<std::vector<uint32_t>>& groups,
                  uint64_t seed) {
  Rng rng(seed, 5);
  double angle = 0.0, distance = 0.0;
  size_t pairs = 0;
  for (const std::vector<uint32_t>& g : groups) {
    if (g.size() < 2) continue;
    for (size_t i = 0; i < g.size(); ++i) {
      uint32_t j = rng.uniformInt(uint32_t(g.size() - 1));
      if (j >= i) ++j;  // another ray of the group
      const Ray a = rays.get(g[i]), b = rays.get(g[j]);
      const float c = glm::dot(glm::normalize(a.dir), glm::normalize(b.dir));
      angle += std::acos(std::clamp(double(c), -1.0, 1.0));
      distance += glm::distance(a.origin, b.origin);
      ++pairs;
    }
  }
  return {angle / double(pairs), distance / double(pairs)};
}

std::vector<std::vector<uint32_t>> cacheBuckets(const RayBatch& rays, uint32_t bucket_size) {
  RayCache cache(RayCacheOptions{bucket_size, 11});
  cache.insert(rays);
  std::vector<std::vector<uint32_t>> out;
  while (!cache.empty()) out.push_back(cache.nextBucket());
  return out;
}

std::vector<std::vector<uint32_t>> inputOrderBuckets(size_t n, uint32_t bucket_size) {
  std::vector<std::vector<uint32_t>> out;
  for (size_t i = 0; i < n; i += bucket_size) {
    out.emplace_back();
    for (size_t j = i; j < std::min(n, i + bucket_size); ++j) out.back().push_back(uint32_t(j));
  }
  return out;
}

TEST(RayCache, BucketsAreCoherentInOriginAndDirection) {
  // Random origins in a cube, random directions: coherence has to come from the cache.
  const RayBatch rays = makeRays(Kind::kRandom, 1 << 18, 21);
  const Spread whole = pairSpread(rays, inputOrderBuckets(rays.size(), rays.size()), 1);
  const Spread plain = pairSpread(rays, inputOrderBuckets(rays.size(), 256), 1);
  const Spread cached = pairSpread(rays, cacheBuckets(rays, 256), 1);
  // Uniform directions: pairs are 90 degrees apart on average; the metric sees no coherence
  // in input order.
  EXPECT_NEAR(whole.angle, 1.5708, 0.02);
  EXPECT_GT(plain.angle, 0.95 * whole.angle);
  EXPECT_GT(plain.distance, 0.95 * whole.distance);
  // 1024 buckets over five dimensions: two halvings per dimension, a quarter of the spread.
  EXPECT_LT(cached.angle, 0.45 * whole.angle) << cached.angle << " vs " << whole.angle;
  EXPECT_LT(cached.distance, 0.45 * whole.distance) << cached.distance << " vs " << whole.distance;
}

TEST(RayCache, PointSourceBucketsAreTightCones) {
  // Shadow or photon rays from one point: all the splitting goes to direction.
  Rng rng(8, 8);
  RayBatch rays;
  for (int i = 0; i < 1 << 16; ++i) {
    Ray r;
    r.origin = glm::vec3(0.3f, 1.0f, -2.0f);
    r.dir = randomDirection(rng);
    append(rays, r);
  }
  const Spread whole = pairSpread(rays, inputOrderBuckets(rays.size(), rays.size()), 2);
  const Spread cached = pairSpread(rays, cacheBuckets(rays, 256), 2);
  EXPECT_LT(cached.angle, 0.14 * whole.angle) << cached.angle << " vs " << whole.angle;

  // Parallel rays from random origins: all the splitting goes to origins.
  RayBatch parallel;
  for (int i = 0; i < 1 << 16; ++i) {
    Ray r;
    r.origin = randomInBox(rng, -10.0f, 10.0f);
    r.dir = glm::vec3(0.0f, -1.0f, 0.0f);
    append(parallel, r);
  }
  const Spread pwhole = pairSpread(parallel, inputOrderBuckets(parallel.size(), 1 << 16), 3);
  const Spread pcached = pairSpread(parallel, cacheBuckets(parallel, 256), 3);
  EXPECT_LT(pcached.distance, 0.25 * pwhole.distance)
      << pcached.distance << " vs " << pwhole.distance;
}

// --------------------------------------------------------------------------------------------
// Tracing through the cache changes nothing but the order of work.

void expectSameHits(const RayEngine& engine, const RayBatch& rays, const std::string& what) {
  size_t hit_count = 0;
  for (const uint32_t bucket_size : kBucketSizes) {
    HitBatch hits;
    RayCacheStats stats;
    traceThroughCache(engine, rays, hits, RayCacheOptions{bucket_size, 5}, &stats);
    ASSERT_EQ(hits.size(), rays.size());
    EXPECT_EQ(stats.buckets, (rays.size() + bucket_size - 1) / bucket_size);
    EXPECT_EQ(stats.rays, rays.size());
    hit_count = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      const Hit expected = engine.intersect(rays.get(i));
      const Hit got = hits.get(i);
      ASSERT_EQ(got.triangle, expected.triangle)
          << what << " ray " << i << " bucket " << bucket_size;
      ASSERT_EQ(std::bit_cast<uint32_t>(got.t), std::bit_cast<uint32_t>(expected.t)) << what << i;
      ASSERT_EQ(std::bit_cast<uint32_t>(got.u), std::bit_cast<uint32_t>(expected.u)) << what << i;
      ASSERT_EQ(std::bit_cast<uint32_t>(got.v), std::bit_cast<uint32_t>(expected.v)) << what << i;
      hit_count += expected.hit();
    }
  }
  // Both hits and misses are exercised.
  EXPECT_GT(hit_count, rays.size() / 5) << what;
  EXPECT_LT(hit_count, rays.size()) << what;
}

TEST(RayCache, TraceThroughCacheMatchesTheEngineOnTheTeapot) {
  Expected<Scene> teapot = loadScene(test::dataPath("teapot.ply"));
  ASSERT_TRUE(teapot.ok()) << teapot.error().describe();
  const Mesh& mesh = teapot->meshes.at(0);
  const RayEngine engine = RayEngine::build(mesh.positions, mesh.triangles);
  const Bounds3 box = engine.bounds();
  const glm::vec3 centre = 0.5f * (box.lo + box.hi);
  const float radius = glm::distance(box.lo, box.hi);
  RayBatch rays;
  addFan(rays, 6000, centre + glm::vec3(0.3f, 0.4f, 1.0f) * radius, centre, 0.4f);
  Rng rng(12, 1);
  for (int i = 0; i < 6000; ++i) {  // from around the teapot at points of its box
    Ray r;
    r.origin = centre + randomInBox(rng, -radius, radius);
    const glm::vec3 aim = box.lo + (box.hi - box.lo) * randomInBox(rng, 0.0f, 1.0f);
    r.dir = aim - r.origin;  // not unit length: t in units of |dir|
    if (i % 4 == 1) r.tmax = 0.5f;
    append(rays, r);
  }
  expectSameHits(engine, rays, "teapot");
}

TEST(RayCache, TraceThroughCacheMatchesTheEngineOnATriangleSoup) {
  Rng rng(31, 1);
  std::vector<glm::vec3> positions;
  std::vector<glm::uvec3> triangles;
  for (uint32_t i = 0; i < 3000; ++i) {
    const glm::vec3 c = randomInBox(rng, -1.0f, 1.0f);
    for (int k = 0; k < 3; ++k) positions.push_back(c + 0.1f * randomInBox(rng, -1.0f, 1.0f));
    triangles.emplace_back(3 * i, 3 * i + 1, 3 * i + 2);
  }
  const RayEngine engine = RayEngine::build(positions, triangles);
  const RayBatch rays = makeRays(Kind::kMixed, 8000, 6);
  expectSameHits(engine, rays, "soup");
}

// A broken contract throws InternalError naming what was wrong (core/check.h), so that a caller
// of the library survives it.
TEST(RayCacheContract, ZeroBucketSizeIsAContractViolation) {
  expectInternalError([] { RayCache cache(RayCacheOptions{0, 0}); }, "bucket_size");
}

TEST(RayCacheContract, SubsetIndexOutOfRangeIsAContractViolation) {
  const RayBatch rays = makeRays(Kind::kRandom, 10, 1);
  RayCache cache;
  const std::vector<uint32_t> subset = {3, 10};
  expectInternalError([&] { cache.insert(rays, subset); }, "subset[1] = 10 of 10 rays");
}

}  // namespace
}  // namespace penumbra
