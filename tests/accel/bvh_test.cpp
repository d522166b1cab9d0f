// The BVH and the CPU Ray Engine against brute force and against Embree.
#include "penumbra/accel/bvh.h"
#include "penumbra/accel/wide_bvh.h"
#include "penumbra/core/rng.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/kernels/ray_triangle.h"
#include "penumbra/raytrace/camera_rays.h"
#include "penumbra/raytrace/cpu_avx512.h"
#include "penumbra/raytrace/cpu_packet.h"
#include "penumbra/raytrace/ray_engine.h"
#include "penumbra/raytrace/ray_order.h"
#include "penumbra/raytrace/ray_sets.h"
#include "support/embree_oracle.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numeric>

namespace penumbra {
namespace {

using test::randomDirection;
using test::randomInBox;

constexpr float kInf = std::numeric_limits<float>::infinity();

struct Soup {
  std::vector<glm::vec3> positions;
  std::vector<glm::uvec3> triangles;
};

Soup randomSoup(uint64_t seed, int n, float size) {
  Rng rng(seed, 1);
  Soup s;
  for (int i = 0; i < n; ++i) {
    const glm::vec3 c = randomInBox(rng, -1.0f, 1.0f);
    const uint32_t base = uint32_t(s.positions.size());
    for (int k = 0; k < 3; ++k) s.positions.push_back(c + size * randomInBox(rng, -1.0f, 1.0f));
    s.triangles.emplace_back(base, base + 1, base + 2);
  }
  return s;
}

// Closest hit by testing every triangle, with the Ray Engine's tie rule (lowest index).
Hit bruteForce(const Soup& s, const Ray& ray) {
  const WatertightRay wr = makeWatertightRay(ray.origin, ray.dir);
  Hit best;
  float tmax = ray.tmax;
  for (size_t i = 0; i < s.triangles.size(); ++i) {
    const glm::uvec3 t = s.triangles[i];
    float th, u, v;
    if (intersectTriangle(wr, s.positions[t.x], s.positions[t.y], s.positions[t.z], ray.tmin, tmax,
                          th, u, v)) {
      if (th < tmax || !best.hit()) {
        best = Hit{int32_t(i), th, u, v};
        tmax = th;
      }
    }
  }
  return best;
}

TEST(Bvh, EveryTriangleIsReferencedOnceAndLeavesBoundTheirTriangles) {
  const Soup s = randomSoup(7, 5000, 0.05f);
  const Bvh bvh = buildBvh(s.positions, s.triangles);
  std::vector<int> seen(s.triangles.size(), 0);
  for (uint32_t r : bvh.refs) ++seen[r];
  for (int c : seen) ASSERT_EQ(c, 1);
  for (const BvhNode& n : bvh.nodes) {
    if (!n.isLeaf()) {
      // Children lie inside their parent.
      for (uint32_t c : {n.index, n.index + 1}) {
        EXPECT_TRUE(glm::all(glm::greaterThanEqual(bvh.nodes[c].lo, n.lo)));
        EXPECT_TRUE(glm::all(glm::lessThanEqual(bvh.nodes[c].hi, n.hi)));
      }
      continue;
    }
    EXPECT_LE(n.count, 8u);
    for (uint32_t i = n.index; i < n.index + n.count; ++i) {
      const glm::uvec3 t = s.triangles[bvh.refs[i]];
      for (uint32_t v : {t.x, t.y, t.z}) {
        EXPECT_TRUE(glm::all(glm::greaterThanEqual(s.positions[v], n.lo)));
        EXPECT_TRUE(glm::all(glm::lessThanEqual(s.positions[v], n.hi)));
      }
    }
  }
  EXPECT_LE(bvh.depth(), kMaxBvhDepth);
}

// Total surface area of the wide inner nodes: the part of the SAH cost the collapse chooses.
double wideInnerArea(const Bvh8& wide) {
  double sum = 0.0;
  for (const Bvh8Node& n : wide.nodes) {
    Bounds3 box;
    for (int i = 0; i < 8; ++i) {
      if (n.child[i] == Bvh8Node::kEmpty) continue;
      box.extend(glm::vec3(n.lo_x[i], n.lo_y[i], n.lo_z[i]));
      box.extend(glm::vec3(n.hi_x[i], n.hi_y[i], n.hi_z[i]));
    }
    sum += box.area();
  }
  return sum;
}

// The same for the greedy collapse (open the largest inner child until eight), as reference.
double greedyInnerArea(const Bvh& bvh, uint32_t b) {
  std::vector<uint32_t> kids = {bvh.nodes[b].index, bvh.nodes[b].index + 1};
  while (kids.size() < 8) {
    int best = -1;
    float best_area = -1.0f;
    for (size_t i = 0; i < kids.size(); ++i) {
      const BvhNode& c = bvh.nodes[kids[i]];
      const float a = Bounds3{c.lo, c.hi}.area();
      if (!c.isLeaf() && a > best_area) best_area = a, best = int(i);
    }
    if (best < 0) break;
    const uint32_t open = kids[size_t(best)];
    kids[size_t(best)] = bvh.nodes[open].index;
    kids.push_back(bvh.nodes[open].index + 1);
  }
  double sum = Bounds3{bvh.nodes[b].lo, bvh.nodes[b].hi}.area();
  for (uint32_t k : kids) {
    if (!bvh.nodes[k].isLeaf()) sum += greedyInnerArea(bvh, k);
  }
  return sum;
}

// The optimal collapse (Ylitie et al. 2017) keeps every canonical leaf exactly once, with its
// box, and never costs more than the greedy collapse; on the bunny it fills the wide nodes.
TEST(Bvh8, OptimalCollapseKeepsTheLeavesAndBeatsGreedy) {
  Expected<Scene> bunny = loadScene(test::dataPath("bunny.ply"));
  ASSERT_TRUE(bunny.ok());
  const Soup soups[] = {randomSoup(3, 3000, 0.05f),
                        randomSoup(4, 200, 0.3f),
                        {bunny->meshes[0].positions, bunny->meshes[0].triangles}};
  for (const Soup& s : soups) {
    const Bvh bvh = buildBvh(s.positions, s.triangles, RayEngine::cpuBuildOptions());
    const Bvh8 wide = collapseToBvh8(bvh);
    size_t canonical_leaves = 0;
    for (const BvhNode& n : bvh.nodes) canonical_leaves += n.isLeaf() ? 1 : 0;
    ASSERT_EQ(wide.leaves.size(), canonical_leaves);
    std::vector<int> seen(bvh.refs.size(), 0);
    size_t children = 0;
    for (const Bvh8Node& n : wide.nodes) {
      for (int i = 0; i < 8; ++i) {
        if (n.child[i] == Bvh8Node::kEmpty || !bvh8IsLeaf(n.child[i])) {
          children += n.child[i] == Bvh8Node::kEmpty ? 0 : 1;
          continue;
        }
        ++children;
        const Bvh8::Leaf& leaf = wide.leaves[bvh8LeafIndex(n.child[i])];
        ASSERT_EQ(leaf.count, bvh8LeafCount(n.child[i]));
        for (uint32_t r = leaf.first; r < leaf.first + leaf.count; ++r) {
          ++seen[r];
          const glm::uvec3 t = s.triangles[bvh.refs[r]];
          for (uint32_t v : {t.x, t.y, t.z}) {
            EXPECT_GE(s.positions[v].x, n.lo_x[i]);
            EXPECT_LE(s.positions[v].x, n.hi_x[i]);
            EXPECT_GE(s.positions[v].z, n.lo_z[i]);
            EXPECT_LE(s.positions[v].z, n.hi_z[i]);
          }
        }
      }
    }
    for (int c : seen) ASSERT_EQ(c, 1);
    EXPECT_LE(wideInnerArea(wide), greedyInnerArea(bvh, 0) * (1.0 + 1e-6));
    if (s.triangles.size() > 50000) {
      // The greedy collapse averaged 3.7 children per wide node here.
      EXPECT_GT(double(children) / double(wide.nodes.size()), 5.5);
      EXPECT_LT(wideInnerArea(wide), 0.95 * greedyInnerArea(bvh, 0));  // measured 0.92
    }
  }
}

// The quantised nodes the CPU traverses (accel/wide_bvh.h): every dequantised box contains its
// child's float box, in the kernels' arithmetic, and is at most a step or two larger; on the
// bunny, on a scene far from the origin, and on flat and point-sized boxes.
TEST(Bvh8, QuantisedBoxesContainTheirChildren) {
  const auto check = [](const Bvh8Node& n, const char* what) {
    const Bvh8QNode q = quantizeBvh8Node(n);
    const float* lo[3] = {n.lo_x, n.lo_y, n.lo_z};
    const float* hi[3] = {n.hi_x, n.hi_y, n.hi_z};
    const uint8_t* qlo[3] = {q.lo_x, q.lo_y, q.lo_z};
    const uint8_t* qhi[3] = {q.hi_x, q.hi_y, q.hi_z};
    for (int i = 0; i < 8; ++i) {
      ASSERT_EQ(q.child[i], n.child[i]);
      ASSERT_EQ((q.valid >> i & 1) != 0, n.child[i] != Bvh8Node::kEmpty) << what;
      if (n.child[i] == Bvh8Node::kEmpty) continue;
      for (int a = 0; a < 3; ++a) {
        ASSERT_EQ(std::exp2(std::round(std::log2(q.scale[a]))), q.scale[a]) << "a power of two";
        const float plane_lo = q.origin[a] + float(qlo[a][i]) * q.scale[a];
        const float plane_hi = q.origin[a] + float(qhi[a][i]) * q.scale[a];
        ASSERT_LE(plane_lo, lo[a][i]) << what << " slot " << i << " axis " << a;
        ASSERT_GE(plane_hi, hi[a][i]) << what << " slot " << i << " axis " << a;
        // Loose by rounding only: two steps, or the float spacing where steps are finer.
        const float slack = 2.0f * q.scale[a] + 4.0f * std::fabs(q.origin[a]) * 1.2e-7f;
        ASSERT_LE(lo[a][i] - plane_lo, slack) << what;
        ASSERT_LE(plane_hi - hi[a][i], slack) << what;
      }
    }
  };
  Expected<Scene> bunny = loadScene(test::dataPath("bunny.ply"));
  ASSERT_TRUE(bunny.ok());
  const Mesh& mesh = bunny->meshes.at(0);
  for (const glm::vec3 offset : {glm::vec3(0.0f), glm::vec3(1e5f, -3e4f, 7e3f)}) {
    std::vector<glm::vec3> moved = mesh.positions;
    for (glm::vec3& p : moved) p += offset;
    const Bvh8 wide = collapseToBvh8(buildBvh(moved, mesh.triangles));
    ASSERT_GT(wide.nodes.size(), 1000u);
    for (const Bvh8Node& n : wide.nodes) check(n, "bunny");
  }
  // Flat children (a wall), a point, a child as large as the node, empty slots.
  Bvh8Node n;
  const float inf = std::numeric_limits<float>::infinity();
  for (int i = 0; i < 8; ++i) {
    n.lo_x[i] = n.lo_y[i] = n.lo_z[i] = inf;
    n.hi_x[i] = n.hi_y[i] = n.hi_z[i] = -inf;
    n.child[i] = Bvh8Node::kEmpty;
  }
  const float boxes[4][6] = {{0.0f, 0.0f, -5.0f, 0.0f, 3.0f, 5.0f},
                             {1.25f, 1.25f, 1.25f, 1.25f, 1.25f, 1.25f},
                             {-2.0f, -1.0f, -5.0f, 7.0f, 3.0f, 5.0f},
                             {1e-30f, 0.3f, 0.0f, 2e-30f, 0.3f, 1e-7f}};
  for (int i = 0; i < 4; ++i) {
    n.lo_x[i] = boxes[i][0], n.lo_y[i] = boxes[i][1], n.lo_z[i] = boxes[i][2];
    n.hi_x[i] = boxes[i][3], n.hi_y[i] = boxes[i][4], n.hi_z[i] = boxes[i][5];
    n.child[i] = int32_t(i + 1);
  }
  check(n, "constructed node");
}

// Rays against a scene far from the origin and against axis-aligned walls (flat boxes, planes
// on quantisation steps): the same answers as brute force, and none escapes a closed box of
// big quads.
TEST(RayEngine, FarFromTheOriginAndOnFlatWallsAnswersStayExact) {
  Soup s = randomSoup(17, 3000, 0.05f);
  const glm::vec3 offset(2.5e4f, -1.0e4f, 3.0e3f);
  for (glm::vec3& p : s.positions) p = offset + 100.0f * p;
  const RayEngine engine = RayEngine::build(s.positions, s.triangles);
  Rng rng(8, 8);
  for (int i = 0; i < 3000; ++i) {
    const Ray ray{offset + 150.0f * randomInBox(rng, -1.0f, 1.0f), 0.0f, randomDirection(rng),
                  kInf};
    const Hit a = engine.intersect(ray), b = bruteForce(s, ray);
    ASSERT_EQ(a.triangle, b.triangle) << i;
    if (b.hit()) {
      ASSERT_EQ(a.t, b.t) << i;
    }
  }
  // A closed box of 10 x 10 quads per face, two triangles each.
  Soup box;
  const int n = 10;
  for (int axis = 0; axis < 3; ++axis) {
    for (int side = 0; side < 2; ++side) {
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
          glm::vec3 c[4];
          for (int k = 0; k < 4; ++k) {
            glm::vec3 p;
            p[axis] = side ? 3.0f : -1.0f;
            p[(axis + 1) % 3] = -1.0f + 4.0f * float(i + (k == 1 || k == 2)) / float(n);
            p[(axis + 2) % 3] = -1.0f + 4.0f * float(j + (k >= 2)) / float(n);
            c[k] = p;
          }
          const uint32_t base = uint32_t(box.positions.size());
          for (const glm::vec3& p : c) box.positions.push_back(p);
          box.triangles.emplace_back(base, base + 1, base + 2);
          box.triangles.emplace_back(base, base + 2, base + 3);
        }
      }
    }
  }
  const RayEngine walls = RayEngine::build(box.positions, box.triangles);
  int escaped = 0;
  for (int i = 0; i < 100000; ++i) {
    // Half of the rays run along the walls' grid lines' directions.
    glm::vec3 d = randomDirection(rng);
    if (i % 2) d[i % 3] = 0.0f;
    if (glm::length(d) < 1e-3f) continue;
    const Ray ray{glm::vec3(1.0f) + randomInBox(rng, -1.5f, 1.5f), 0.0f, d, kInf};
    escaped += !walls.intersect(ray).hit();
  }
  EXPECT_EQ(escaped, 0);
}

TEST(Bvh, DepthStaysBoundedOnPathologicalInput) {
  // Triangles at exponentially growing distances defeat the SAH's balance.
  Soup s;
  for (int i = 0; i < 4000; ++i) {
    const float x = std::ldexp(1.0f, i % 120 - 60);
    const uint32_t b = uint32_t(s.positions.size());
    s.positions.insert(s.positions.end(), {{x, 0, 0}, {x * 1.0001f, 1e-30f, 0}, {x, 0, 1e-30f}});
    s.triangles.emplace_back(b, b + 1, b + 2);
  }
  const Bvh bvh = buildBvh(s.positions, s.triangles);
  EXPECT_LE(bvh.depth(), kMaxBvhDepth);
}

TEST(RayEngine, ClosestHitsIdenticalToBruteForceOnRandomSoups) {
  for (uint64_t seed : {1u, 2u, 3u}) {
    const Soup s = randomSoup(seed, 3000, seed == 3 ? 0.5f : 0.05f);
    const RayEngine engine = RayEngine::build(s.positions, s.triangles);
    Rng rng(seed, 99);
    for (int i = 0; i < 3000; ++i) {
      Ray ray;
      ray.origin = randomInBox(rng, -1.5f, 1.5f);
      ray.dir = randomDirection(rng);
      if (i % 3 == 1) ray.tmax = 0.5f;
      if (i % 3 == 2) ray.tmin = 0.2f;
      const Hit a = engine.intersect(ray);
      const Hit b = bruteForce(s, ray);
      ASSERT_EQ(a.triangle, b.triangle) << "seed " << seed << " ray " << i;
      if (b.hit()) {
        ASSERT_EQ(a.t, b.t);
        ASSERT_EQ(a.u, b.u);
        ASSERT_EQ(a.v, b.v);
      }
      ASSERT_EQ(engine.occluded(ray), b.hit());
    }
  }
}

// A soup large enough (over 8 MiB of nodes and leaves) for batches to be reordered, built once
// for the tests of the order.
const RayEngine& largeSoupEngine() {
  static const RayEngine engine = [] {
    const Soup s = randomSoup(12, 160000, 0.01f);
    return RayEngine::build(s.positions, s.triangles);
  }();
  return engine;
}

// Large incoherent batches on a large scene are traced in coherentRayOrder: a permutation,
// grouped by octant and along the Morton curve, whose answers are each ray's own.
TEST(RayEngine, ReorderedBatchesGiveEachRayItsOwnAnswer) {
  const RayEngine& engine = largeSoupEngine();
  Rng rng(6, 6);
  RayBatch rays;
  rays.resize(70000);
  for (size_t i = 0; i < rays.size(); ++i) {
    rays.set(i, Ray{randomInBox(rng, -1.0f, 1.0f), 0.0f, randomDirection(rng),
                    i % 3 == 0 ? 0.05f : kInf});
  }
  ASSERT_GE(engine.memoryBytes(), size_t(8) << 20);
  ASSERT_TRUE(engine.reorders(rays));
  const LargeVector<uint32_t> order = coherentRayOrder(rays, engine.bounds());
  // The parallel radix sort is the stable sort by (octant, Morton code of the origin's cell).
  {
    const Bounds3 b = engine.bounds();
    const auto spread = [](uint32_t x) {
      uint32_t r = 0;
      for (int bit = 0; bit < 9; ++bit) r |= ((x >> bit) & 1u) << (3 * bit);
      return r;
    };
    std::vector<uint32_t> key(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) {
      const glm::vec3 o{rays.ox[i], rays.oy[i], rays.oz[i]};
      uint32_t cell[3];
      for (int a = 0; a < 3; ++a) {
        const float c = (o[a] - b.lo[a]) * (511.0f / (b.hi[a] - b.lo[a]));
        cell[a] = uint32_t(std::clamp(c, 0.0f, 511.0f));
      }
      key[i] = uint32_t(rays.dx[i] < 0.0f) << 29 | uint32_t(rays.dy[i] < 0.0f) << 28 |
               uint32_t(rays.dz[i] < 0.0f) << 27 | spread(cell[0]) | spread(cell[1]) << 1 |
               spread(cell[2]) << 2;
    }
    std::vector<uint32_t> expected(rays.size());
    std::iota(expected.begin(), expected.end(), 0u);
    std::stable_sort(expected.begin(), expected.end(),
                     [&](uint32_t a, uint32_t c) { return key[a] < key[c]; });
    ASSERT_TRUE(std::equal(expected.begin(), expected.end(), order.begin()));
  }
  std::vector<uint8_t> seen(rays.size(), 0);
  int octant_changes = 0;
  const auto octant = [&](uint32_t i) {
    return int(rays.dx[i] < 0.0f) * 4 + int(rays.dy[i] < 0.0f) * 2 + int(rays.dz[i] < 0.0f);
  };
  for (size_t j = 0; j < order.size(); ++j) {
    ASSERT_LT(order[j], rays.size());
    ASSERT_EQ(seen[order[j]]++, 0) << "ray " << order[j] << " twice";
    if (j > 0) {
      ASSERT_GE(octant(order[j]), octant(order[j - 1]));
      octant_changes += octant(order[j]) != octant(order[j - 1]);
    }
  }
  EXPECT_EQ(octant_changes, 7);
  HitBatch hits;
  std::vector<uint8_t> occ;
  engine.intersect(rays, hits);
  engine.occluded(rays, occ);
  size_t hit_count = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    const Hit h = engine.intersect(rays.get(i));
    ASSERT_EQ(hits.triangle[i], h.triangle) << i;
    ASSERT_EQ(hits.t[i], h.t) << i;
    ASSERT_EQ(occ[i] != 0, h.hit()) << i;
    hit_count += h.hit();
  }
  EXPECT_GT(hit_count, rays.size() / 10);
  // Camera rays in scanline order keep their order (and their packets).
  RayBatch camera = cameraRaySet(Camera{}, 300, 240);
  EXPECT_FALSE(engine.reorders(camera));
}

// Rays from outside the scene (origins on a sphere around it) keep their order: the sort keys on
// the origin, which tells nothing of where such rays go. Their answers are each ray's own.
TEST(RayEngine, BatchesFromOutsideTheSceneKeepTheirOrder) {
  const RayEngine& engine = largeSoupEngine();
  Rng rng(7, 7);
  RayBatch rays;
  rays.resize(70000);
  for (size_t i = 0; i < rays.size(); ++i) {
    const glm::vec3 o = 3.0f * randomDirection(rng);
    rays.set(i, Ray{o, 0.0f, randomInBox(rng, -1.0f, 1.0f) - o, kInf});
  }
  ASSERT_GE(engine.memoryBytes(), size_t(8) << 20);
  EXPECT_FALSE(batchStartsInside(rays, engine.bounds()));
  EXPECT_FALSE(engine.reorders(rays));
  // Mixed batches: a quarter of the rays from inside is not enough, three quarters are.
  RayBatch mixed = rays;
  const auto start_inside = [&](size_t residue) {
    for (size_t i = residue; i < mixed.size(); i += 4) {
      mixed.set(i, Ray{randomInBox(rng, -1.0f, 1.0f), 0.0f, randomDirection(rng), kInf});
    }
  };
  start_inside(0);
  EXPECT_FALSE(batchStartsInside(mixed, engine.bounds()));
  start_inside(1);
  start_inside(2);
  EXPECT_TRUE(batchStartsInside(mixed, engine.bounds()));
  HitBatch hits;
  engine.intersect(rays, hits);
  size_t hit_count = 0;
  for (size_t i = 0; i < rays.size(); i += 7) {
    const Hit h = engine.intersect(rays.get(i));
    ASSERT_EQ(hits.triangle[i], h.triangle) << i;
    ASSERT_EQ(hits.t[i], h.t) << i;
    hit_count += h.hit();
  }
  EXPECT_GT(hit_count, rays.size() / 70);
}

TEST(RayEngine, BatchesMatchSingleRaysInInputOrder) {
  const Soup s = randomSoup(11, 2000, 0.08f);
  const RayEngine engine = RayEngine::build(s.positions, s.triangles);
  Rng rng(5, 5);
  RayBatch rays;
  rays.resize(10000);
  for (size_t i = 0; i < rays.size(); ++i) {
    rays.set(i, Ray{randomInBox(rng, -1.5f, 1.5f), 0.0f, randomDirection(rng), kInf});
  }
  HitBatch hits;
  std::vector<uint8_t> occ;
  engine.intersect(rays, hits);
  engine.occluded(rays, occ);
  ASSERT_EQ(hits.size(), rays.size());
  size_t hit_count = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    const Hit h = engine.intersect(rays.get(i));
    ASSERT_EQ(hits.triangle[i], h.triangle);
    ASSERT_EQ(hits.t[i], h.t);
    ASSERT_EQ(occ[i] != 0, h.hit());
    hit_count += h.hit();
  }
  EXPECT_GT(hit_count, rays.size() / 10);  // the test exercises hits, not only misses
}

// Camera rays travel as packets (raytrace/cpu_packet.h); their hits must be bit-identical to
// single-ray tracing, on the bunny and on a soup with ties and edge hits (an axis-aligned grid
// seen straight on, where many rays pass exactly through shared edges and vertices).
TEST(RayEngine, PacketsGiveTheSingleRayAnswers) {
  Expected<Scene> bunny = loadScene(test::dataPath("bunny.ply"));
  ASSERT_TRUE(bunny.ok());
  Soup grid;
  for (int y = 0; y <= 16; ++y) {
    for (int x = 0; x <= 16; ++x)
      grid.positions.emplace_back(float(x) / 16.0f, float(y) / 16.0f, 0.0f);
  }
  for (uint32_t y = 0; y < 16; ++y) {
    for (uint32_t x = 0; x < 16; ++x) {
      const uint32_t a = y * 17 + x;
      grid.triangles.emplace_back(a, a + 1, a + 18);
      grid.triangles.emplace_back(a, a + 18, a + 17);
    }
  }
  struct Case {
    std::vector<glm::vec3> positions;
    std::vector<glm::uvec3> triangles;
    Camera camera;
  };
  std::vector<Case> cases;
  cases.push_back({bunny->meshes[0].positions, bunny->meshes[0].triangles, defaultCamera(*bunny)});
  Camera straight;
  straight.position = glm::vec3(0.5f, 0.5f, 2.0f);
  straight.look_at = glm::vec3(0.5f, 0.5f, 0.0f);
  straight.vertical_fov = 0.5f;
  cases.push_back({grid.positions, grid.triangles, straight});
  for (const Case& c : cases) {
    const RayEngine engine = RayEngine::build(c.positions, c.triangles);
    const CameraRays camera(c.camera, 128, 128);
    RayBatch rays;
    rays.resize(128 * 128);
    for (int y = 0; y < 128; ++y) {
      for (int x = 0; x < 128; ++x) {
        Ray r = camera.ray(float(x) + 0.5f, float(y) + 0.5f);
        if (x % 7 == 3) r.tmax = 1.5f;  // mixed intervals inside packets
        rays.set(size_t(y) * 128 + size_t(x), r);
      }
    }
    size_t packets = 0;
    for (size_t i = 0; i + 8 <= rays.size(); i += 8) packets += packetEligible(rays, i);
    EXPECT_GT(packets, rays.size() / 8 / 2);  // most camera rays travel as packets
    HitBatch batch;
    engine.intersect(rays, batch);
    size_t hit_count = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      const Hit h = engine.intersect(rays.get(i));
      ASSERT_EQ(batch.triangle[i], h.triangle) << i;
      ASSERT_EQ(batch.t[i], h.t) << i;
      ASSERT_EQ(batch.u[i], h.u) << i;
      ASSERT_EQ(batch.v[i], h.v) << i;
      hit_count += h.hit();
    }
    EXPECT_GT(hit_count, rays.size() / 10);
  }
}

// The portable scalar kernels, the AVX2 kernels (boxes, leaf blocks, packets) and the AVX-512
// kernels (the fused slab test on float boxes) give the same answers bit for bit, so the run-time
// choice between them never changes a result. The rays include origins on the soup's triangles
// (grazing and touching boxes), axis-parallel directions (infinite reciprocals) and origins far
// out (where o / d loses the most to rounding).
TEST(RayEngine, ScalarAvx2AndAvx512KernelsAgree) {
  if (!cpuHasAvx2()) GTEST_SKIP() << "this CPU has no AVX2: only the scalar kernels exist here";
  const Soup s = randomSoup(21, 4000, 0.06f);
  RayEngine best = RayEngine::build(s.positions, s.triangles);
  RayEngine avx2 = RayEngine::build(s.positions, s.triangles);
  avx2.useIsa(CpuIsa::kAvx2);
  ASSERT_EQ(avx2.isa(), CpuIsa::kAvx2);
  ASSERT_EQ(best.isa(), cpuHasAvx512() ? CpuIsa::kAvx512 : CpuIsa::kAvx2);
  RayEngine scalar = RayEngine::build(s.positions, s.triangles);
  scalar.useIsa(CpuIsa::kScalar);
  ASSERT_EQ(scalar.isa(), CpuIsa::kScalar);
  Rng rng(4, 4);
  RayBatch rays;
  rays.resize(40000);
  for (size_t i = 0; i < rays.size(); ++i) {
    glm::vec3 o = randomInBox(rng, -1.5f, 1.5f);
    glm::vec3 d = randomDirection(rng);
    switch (i % 16) {
      case 8:
      case 9:
      case 10:
      case 11:  // coherent runs of eight (packets on the AVX2 side)
      case 12:
      case 13:
      case 14:
      case 15:
        o = glm::vec3(0.0f, 0.0f, 2.0f);
        d = glm::normalize(
            glm::vec3(0.001f * float(i % 97) - 0.05f, 0.001f * float(i % 89) - 0.04f, -1.0f));
        break;
      case 1: {  // from a vertex of a triangle
        const glm::uvec3 t = s.triangles[(i / 16) % s.triangles.size()];
        o = s.positions[t[i % 3]];
        break;
      }
      case 2:  // along an axis
        d = glm::vec3(0.0f);
        d[(i / 16) % 3] = (i / 48) % 2 ? 1.0f : -1.0f;
        break;
      case 3:  // from far out, towards the soup
        o = 1000.0f * randomDirection(rng);
        d = glm::normalize(randomInBox(rng, -0.5f, 0.5f) - o);
        break;
      default:
        break;
    }
    rays.set(i, Ray{o, 0.0f, d, i % 5 == 0 ? 1.7f : kInf});
  }
  HitBatch a, b, c;
  best.intersect(rays, a);
  avx2.intersect(rays, b);
  scalar.intersect(rays, c);
  std::vector<uint8_t> oa, ob, oc;
  best.occluded(rays, oa);
  avx2.occluded(rays, ob);
  scalar.occluded(rays, oc);
  size_t hits = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    for (const HitBatch* h : {&b, &c}) {
      ASSERT_EQ(a.triangle[i], h->triangle[i]) << i;
      ASSERT_EQ(a.t[i], h->t[i]) << i;
      ASSERT_EQ(a.u[i], h->u[i]) << i;
      ASSERT_EQ(a.v[i], h->v[i]) << i;
    }
    ASSERT_EQ(oa[i], ob[i]) << i;
    ASSERT_EQ(oa[i], oc[i]) << i;
    hits += a.triangle[i] >= 0;
  }
  EXPECT_GT(hits, rays.size() / 10);
}

// The AVX-512 box test rounds differently from the exact slab test, so it must err only towards
// entering: every child box that a ray enters within [tmin, tmax], by the slab test in double
// precision on the rounded reciprocal, is entered. Boxes of every size from 1e-4 to 1e3, origins
// from inside the boxes to 1e5 away, directions with components down to zero.
TEST(RayEngine, Avx512BoxTestNeverCullsABoxTheRayEnters) {
  if (!cpuHasAvx512()) GTEST_SKIP() << "this CPU has no AVX-512";
  Rng rng(7, 7);
  size_t entered = 0, tests = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    Bvh8Node node;
    const float size = std::pow(10.0f, -4.0f + 7.0f * rng.uniform());
    const glm::vec3 centre = randomInBox(rng, -10.0f, 10.0f);
    for (int i = 0; i < 8; ++i) {
      const glm::vec3 a = centre + size * randomInBox(rng, -1.0f, 1.0f);
      const glm::vec3 b = a + size * glm::vec3(rng.uniform(), rng.uniform(), rng.uniform());
      node.lo_x[i] = a.x, node.lo_y[i] = a.y, node.lo_z[i] = a.z;
      node.hi_x[i] = b.x, node.hi_y[i] = b.y, node.hi_z[i] = b.z;
      node.child[i] = i;
    }
    const float reach = std::pow(10.0f, -4.0f + 9.0f * rng.uniform());
    const glm::vec3 o = centre + reach * randomDirection(rng);
    // Aimed at a point on a face of one of the boxes: the grazing cases rounding decides.
    const int k = trial % 8;
    glm::vec3 target(node.lo_x[k] + rng.uniform() * (node.hi_x[k] - node.lo_x[k]),
                     node.lo_y[k] + rng.uniform() * (node.hi_y[k] - node.lo_y[k]),
                     node.lo_z[k] + rng.uniform() * (node.hi_z[k] - node.lo_z[k]));
    const int face = (trial / 8) % 3;
    target[face] = (trial / 24) % 2 ? (&node.hi_x[k])[16 * face] : (&node.lo_x[k])[16 * face];
    glm::vec3 d = glm::normalize(target - o);
    if (trial % 7 == 0) d[trial % 3] = 0.0f;
    if (trial % 11 == 0) d = glm::vec3(0.0f), d[trial % 3] = 1.0f;
    const float tmin = trial % 5 == 0 ? 0.5f * reach : 0.0f;
    const float tmax = trial % 3 == 0 ? reach : kInf;
    const BoxTesterFloat tester(o, d);
    alignas(32) float t_near[8];
    const uint32_t mask = tester.test(node, tmin, tmax, t_near);
    const float inv[3] = {safeReciprocal(d.x), safeReciprocal(d.y), safeReciprocal(d.z)};
    for (int i = 0; i < 8; ++i) {
      const float lo[3] = {node.lo_x[i], node.lo_y[i], node.lo_z[i]};
      const float hi[3] = {node.hi_x[i], node.hi_y[i], node.hi_z[i]};
      double tn = tmin, tf = tmax;
      for (int a = 0; a < 3; ++a) {
        const double t0 = (double(lo[a]) - double(o[a])) * double(inv[a]);
        const double t1 = (double(hi[a]) - double(o[a])) * double(inv[a]);
        tn = std::max(tn, std::min(t0, t1));
        tf = std::min(tf, std::max(t0, t1));
      }
      ++tests;
      if (tn <= tf) {
        ++entered;
        ASSERT_TRUE((mask >> i) & 1u)
            << "trial " << trial << " child " << i << ": enters at " << tn << ", leaves at " << tf;
      }
    }
  }
  EXPECT_GT(entered, tests / 16);  // most trials enter the box they aim at
}

// A closed, finely tessellated sphere: rays from inside must all hit (watertightness of the
// test and conservativeness of the box test together).
TEST(RayEngine, NoRayEscapesAClosedMesh) {
  Soup s;
  const int n_theta = 200, n_phi = 400;
  for (int i = 0; i <= n_theta; ++i) {
    for (int j = 0; j < n_phi; ++j) {
      const float th = 3.14159265f * float(i) / float(n_theta);
      const float ph = 6.2831853f * float(j) / float(n_phi);
      s.positions.emplace_back(std::sin(th) * std::cos(ph), std::cos(th),
                               std::sin(th) * std::sin(ph));
    }
  }
  for (int i = 0; i < n_theta; ++i) {
    for (int j = 0; j < n_phi; ++j) {
      const uint32_t a = uint32_t(i * n_phi + j), b = uint32_t(i * n_phi + (j + 1) % n_phi);
      const uint32_t c = a + uint32_t(n_phi), d = b + uint32_t(n_phi);
      s.triangles.emplace_back(a, c, b);
      s.triangles.emplace_back(b, c, d);
    }
  }
  const RayEngine engine = RayEngine::build(s.positions, s.triangles);
  Rng rng(3, 3);
  int escaped = 0;
  for (int i = 0; i < 200000; ++i) {
    Ray ray;
    ray.origin = 0.3f * randomInBox(rng, -1.0f, 1.0f);
    ray.dir = randomDirection(rng);
    escaped += !engine.intersect(ray).hit();
  }
  EXPECT_EQ(escaped, 0);
}

// 100k random rays against the Stanford bunny: the same triangle as Embree except at true ties,
// t within 1e-5 relative.
TEST(RayEngine, AgreesWithEmbreeOnTheBunny) {
  Expected<Scene> bunny = loadScene(test::dataPath("bunny.ply"));
  ASSERT_TRUE(bunny.ok()) << bunny.error().describe();
  const Mesh& mesh = bunny->meshes.at(0);
  const RayEngine engine = RayEngine::build(mesh.positions, mesh.triangles);
  const test::EmbreeScene embree(mesh.positions, mesh.triangles);
  const Bounds3 box = engine.bounds();
  Rng rng(2024, 1);
  int hits = 0, ties = 0;
  for (int i = 0; i < 100000; ++i) {
    // Origins around the bunny, aimed at random points inside its box, plus fully random rays.
    Ray ray;
    const glm::vec3 target =
        box.lo + box.extent() * glm::vec3(rng.uniform(), rng.uniform(), rng.uniform());
    ray.origin = box.center() + 1.5f * glm::length(box.extent()) * randomDirection(rng);
    ray.dir = i % 4 == 0 ? randomDirection(rng) : glm::normalize(target - ray.origin);
    const Hit a = engine.intersect(ray);
    const Hit b = embree.intersect(ray);
    ASSERT_EQ(a.hit(), b.hit()) << "ray " << i;
    if (!a.hit()) continue;
    ++hits;
    ASSERT_NEAR(a.t, b.t, 1e-5f * b.t) << "ray " << i;
    if (a.triangle != b.triangle) {
      // A true tie: Embree's triangle is hit at the same distance by our test too.
      const glm::uvec3 t = mesh.triangles[size_t(b.triangle)];
      float tt, u, v;
      const bool tie =
          intersectTriangle(makeWatertightRay(ray.origin, ray.dir), mesh.positions[t.x],
                            mesh.positions[t.y], mesh.positions[t.z], 0.0f, kInf, tt, u, v) &&
          std::fabs(tt - a.t) <= 1e-5f * a.t;
      ASSERT_TRUE(tie) << "ray " << i << ": " << a.triangle << " vs Embree " << b.triangle;
      ++ties;
    }
    // Our barycentrics reproduce our hit point (Embree's differ from ours by up to 1e-3 on
    // near-grazing hits, where barycentrics are ill-conditioned; t is what must agree).
    const glm::uvec3 t = mesh.triangles[size_t(a.triangle)];
    const glm::vec3 p = (1.0f - a.u - a.v) * mesh.positions[t.x] + a.u * mesh.positions[t.y] +
                        a.v * mesh.positions[t.z];
    ASSERT_LT(glm::length(p - (ray.origin + a.t * ray.dir)), 1e-5f * glm::length(box.extent()))
        << "ray " << i;
  }
  EXPECT_GT(hits, 40000);
  EXPECT_LT(ties, 100);
}

}  // namespace
}  // namespace penumbra
