#include "penumbra/raytrace/hybrid.h"

#include "penumbra/core/check.h"
#include "penumbra/core/parallel.h"
#include "penumbra/kernels/ray_triangle.h"
#include "penumbra/raytrace/cpu_simd.h"

#include <tbb/combinable.h>

#include <cmath>
#include <deque>

namespace penumbra {

namespace {

// Nearest hit, exact ties to the lower triangle index (the Ray Engine's rule everywhere).
inline void keepNearest(Hit& best, const Hit& h) {
  if (!h.hit()) return;
  if (!best.hit() || h.t < best.t || (h.t == best.t && h.triangle < best.triangle)) best = h;
}

// Triangles below each node, and the first slot of its subtree.
uint32_t countBelow(const Bvh& bvh, uint32_t node, std::vector<uint32_t>& count,
                    std::vector<uint32_t>& first) {
  const BvhNode& n = bvh.nodes[node];
  if (n.isLeaf()) {
    count[node] = n.count;
    first[node] = n.index;
    return n.count;
  }
  const uint32_t c =
      countBelow(bvh, n.index, count, first) + countBelow(bvh, n.index + 1, count, first);
  count[node] = c;
  first[node] = std::min(first[n.index], first[n.index + 1]);
  return c;
}

}  // namespace

Expected<HybridRayEngine> HybridRayEngine::build(std::span<const glm::vec3> positions,
                                                 std::span<const glm::uvec3> triangles,
                                                 const HybridOptions& options) {
  PENUMBRA_CHECK(options.t_min >= 1 && options.t_min <= options.t_max && options.r_min >= 1);
  HybridRayEngine e;
  e.options_ = options;
  e.cpu_ = RayEngine::build(positions, triangles);
  const Bvh& bvh = e.cpu_.bvh();
  const int tile = int(std::ceil(std::sqrt(double(options.r_min))));
  Expected<GlRasterKernel> gpu = GlRasterKernel::create(positions, triangles, tile, bvh.refs);
  if (!gpu) return gpu.error();
  e.gpu_ = std::move(*gpu);
  e.cell_of_node_.assign(bvh.nodes.size(), -1);
  if (bvh.nodes.empty()) return e;
  std::vector<uint32_t> count(bvh.nodes.size()), first(bvh.nodes.size());
  countBelow(bvh, 0, count, first);
  // The highest nodes with at most t_max triangles become cells when they have at least t_min
  // (sec. 6.2); smaller subtrees stay on the CPU.
  std::vector<uint32_t> todo = {0};
  while (!todo.empty()) {
    const uint32_t node = todo.back();
    todo.pop_back();
    if (count[node] <= options.t_max) {
      if (count[node] >= options.t_min) {
        e.cell_of_node_[node] = int32_t(e.cells_.size());
        e.cells_.push_back({node, first[node], count[node]});
      }
      continue;
    }
    const BvhNode& n = bvh.nodes[node];
    if (!n.isLeaf()) {
      todo.push_back(n.index);
      todo.push_back(n.index + 1);
    }
  }
  return e;
}

void HybridRayEngine::traverse(uint32_t start, const Ray& ray, Hit& hit,
                               std::vector<uint32_t>* cells) const {
  const Bvh& bvh = cpu_.bvh();
  const WatertightRay wr = makeWatertightRay(ray.origin, ray.dir);
  const glm::vec3 inv(safeReciprocal(ray.dir.x), safeReciprocal(ray.dir.y),
                      safeReciprocal(ray.dir.z));
  auto enter = [&](const BvhNode& n, float tmax, float& t_entry) {
    const glm::vec3 t0 = (n.lo - ray.origin) * inv, t1 = (n.hi - ray.origin) * inv;
    const glm::vec3 tn = glm::min(t0, t1), tf = glm::max(t0, t1);
    const float a = std::max(std::max(tn.x, tn.y), std::max(tn.z, ray.tmin));
    const float b = std::min(std::min(tf.x, tf.y), std::min(tf.z, tmax)) * kFarScale;
    t_entry = a;
    return a <= b;
  };
  float tmax = hit.hit() ? hit.t : ray.tmax;
  uint32_t stack[kMaxBvhDepth];
  int sp = 0;
  float t_entry;
  if (!enter(bvh.nodes[start], tmax, t_entry)) return;
  uint32_t node = start;
  for (;;) {
    const BvhNode& n = bvh.nodes[node];
    const int32_t cell = cells ? cell_of_node_[node] : -1;
    if (cell >= 0) {
      cells->push_back(uint32_t(cell));
    } else if (n.isLeaf()) {
      alignas(32) float t[8], u[8], v[8];
      const TriangleBlock8& block = cpu_.blocks()[cpu_.blockOfLeaf(n)];
      uint32_t mask;
#if PENUMBRA_HAVE_AVX2_KERNELS
      if (cpu_.isa() == CpuIsa::kAvx2) {
        mask = intersectBlockAvx2(wr, block, n.count, ray.tmin, tmax, t, u, v);
      } else
#endif
      {
        mask = intersectBlockScalar(wr, block, n.count, ray.tmin, tmax, t, u, v);
      }
      while (mask) {
        const int i = __builtin_ctz(mask);
        mask &= mask - 1;
        keepNearest(hit, Hit{block.id[i], t[i], u[i], v[i]});
      }
      if (hit.hit()) tmax = hit.t;
    } else {
      float ta, tb;
      const bool ha = enter(bvh.nodes[n.index], tmax, ta);
      const bool hb = enter(bvh.nodes[n.index + 1], tmax, tb);
      if (ha && hb) {
        const bool a_first = ta <= tb;
        node = a_first ? n.index : n.index + 1;
        stack[sp++] = a_first ? n.index + 1 : n.index;
        continue;
      }
      if (ha || hb) {
        node = ha ? n.index : n.index + 1;
        continue;
      }
    }
    if (sp == 0) break;
    node = stack[--sp];
  }
}

Status HybridRayEngine::intersect(const RayBatch& rays, HitBatch& hits, HybridStats* stats) const {
  const size_t n = rays.size();
  std::vector<Hit> best(n);
  HybridStats local;
  local.gpu_cells = cells_.size();

  struct Pending {
    GlRasterKernel::Job job;
    std::vector<uint32_t> rays;
  };
  std::deque<Pending> pending;
  std::vector<Hit> out(size_t(gpu_.tile()) * size_t(gpu_.tile()));
  auto collectOne = [&](Pending& p) {
    gpu_.collect(p.job, out.data());
    for (size_t k = 0; k < p.rays.size(); ++k) keepNearest(best[p.rays[k]], out[k]);
  };
  // Collect what the GPU has finished, without waiting.
  auto collectReady = [&] {
    while (!pending.empty() && GlRasterKernel::ready(pending.front().job)) {
      collectOne(pending.front());
      pending.pop_front();
    }
  };

  std::vector<std::vector<uint32_t>> caches(cells_.size());  // per cell: ray indices
  constexpr size_t kChunk = 4096;
  std::vector<std::vector<uint32_t>> cells_of(kChunk);
  for (size_t begin = 0; begin < n; begin += kChunk) {
    const size_t m = std::min(kChunk, n - begin);
    // CPU: traverse, intersecting non-cell leaves, noting the cells each ray enters.
    parallelRange(m, 64, [&](size_t b, size_t e) {
      for (size_t i = b; i < e; ++i) {
        cells_of[i].clear();
        Hit h;
        traverse(0, rays.get(begin + i), h, &cells_of[i]);
        best[begin + i] = h;
      }
    });
    for (size_t i = 0; i < m; ++i) {
      for (uint32_t c : cells_of[i]) {
        std::vector<uint32_t>& cache = caches[c];
        cache.push_back(uint32_t(begin + i));
        if (cache.size() < options_.r_min) continue;
        // A full cache goes to the GPU with the cell's triangles.
        Expected<GlRasterKernel::Job> job =
            gpu_.submit(rays, cache, cells_[c].first, cells_[c].count);
        if (!job) return job.error();
        pending.push_back({std::move(*job), std::move(cache)});
        cache.clear();
        ++local.gpu_batches;
        local.gpu_ray_cells += options_.r_min;
      }
    }
    collectReady();
  }
  // Short caches are forced to the CPU (sec. 6.2) while the GPU finishes.
  std::vector<std::pair<uint32_t, uint32_t>> forced;  // (ray, cell)
  for (size_t c = 0; c < caches.size(); ++c) {
    for (uint32_t r : caches[c]) forced.emplace_back(r, uint32_t(c));
  }
  local.forced_ray_cells = forced.size();
  std::vector<Hit> forced_hits(forced.size());
  parallelRange(forced.size(), 64, [&](size_t b, size_t e) {
    for (size_t i = b; i < e; ++i) {
      Hit h;
      traverse(cells_[forced[i].second].node, rays.get(forced[i].first), h, nullptr);
      forced_hits[i] = h;
    }
  });
  for (size_t i = 0; i < forced.size(); ++i) keepNearest(best[forced[i].first], forced_hits[i]);
  for (Pending& p : pending) collectOne(p);

  hits.resize(n);
  for (size_t i = 0; i < n; ++i) hits.set(i, best[i]);
  if (stats) *stats = local;
  return {};
}

}  // namespace penumbra
