#include "penumbra/raytrace/hybrid.h"

#include "penumbra/core/check.h"
#include "penumbra/core/parallel.h"
#include "penumbra/kernels/ray_triangle.h"
#include "penumbra/raytrace/cpu_simd.h"
#include "penumbra/raytrace/ray_cache.h"

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
  PENUMBRA_CHECK_MSG(options.t_min >= 1 && options.t_min <= options.t_max && options.r_min >= 1,
                     "t_min {} t_max {} r_min {}", options.t_min, options.t_max, options.r_min);
  PENUMBRA_CHECK_MSG(options.cache_rays == 0 || options.cache_rays >= options.r_min,
                     "cache_rays {} r_min {}", options.cache_rays, options.r_min);
  HybridRayEngine e;
  e.options_ = options;
  if (e.options_.cache_rays == 0) {
    e.options_.cache_rays = uint32_t(std::min<uint64_t>(4ull * options.r_min, 0xffffffffull));
  }
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
  const uint32_t r_min = options_.r_min, capacity = options_.cache_rays;
  std::vector<Hit> best(n);
  HybridStats local;
  local.gpu_cells = cells_.size();

  struct Pending {
    GlRasterKernel::Job job;
    std::vector<uint32_t> rays;
  };
  std::deque<Pending> pending;
  std::vector<std::vector<uint32_t>> spare;  // ray lists of collected jobs, for reuse
  std::vector<Hit> out(size_t(gpu_.tile()) * size_t(gpu_.tile()));
  auto collectOne = [&](Pending& p) {
    gpu_.collect(p.job, out.data());
    for (size_t k = 0; k < p.rays.size(); ++k) keepNearest(best[p.rays[k]], out[k]);
    spare.push_back(std::move(p.rays));
  };
  // Collect what the GPU has finished, without waiting.
  auto collectReady = [&] {
    while (!pending.empty() && GlRasterKernel::ready(pending.front().job)) {
      collectOne(pending.front());
      pending.pop_front();
    }
  };

  // The ray cache of each GPU cell that rays entered (sec. 5.3, 6.2), made on the first ray:
  // cells without rays cost nothing. Cache ids number the rays a cell received; ray_of maps
  // them back to ray indices.
  struct CellCache {
    uint32_t cell;
    RayCache cache;
    std::vector<uint32_t> ray_of;   // cache id -> ray index
    std::vector<uint32_t> arrived;  // rays of the current chunk, in order, not yet inserted
  };
  std::vector<CellCache> active;
  std::vector<int32_t> active_of(cells_.size(), -1);  // cell -> index in `active`
  std::vector<uint32_t> bucket;

  // Takes the cache's fullest bucket (exactly R_min rays) to the GPU with the cell's triangles.
  auto submitBucket = [&](CellCache& cc) -> Status {
    cc.cache.nextBucket(bucket);
    PENUMBRA_CHECK(bucket.size() == r_min);
    std::vector<uint32_t> ray_indices;
    if (!spare.empty()) {
      ray_indices = std::move(spare.back());
      spare.pop_back();
    }
    ray_indices.clear();
    for (uint32_t id : bucket) ray_indices.push_back(cc.ray_of[id]);
    const Cell& cell = cells_[cc.cell];
    Expected<GlRasterKernel::Job> job = gpu_.submit(rays, ray_indices, cell.first, cell.count);
    if (!job) return job.error();
    if (stats) {
      local.gpu_triangles += cell.count;
      local.gpu_triangles_culled += gpu_.culledTriangles(job->bound, cell.first, cell.count);
    }
    pending.push_back({std::move(*job), std::move(ray_indices)});
    ++local.gpu_batches;
    local.gpu_ray_cells += r_min;
    return {};
  };

  constexpr size_t kChunk = 4096;
  std::vector<std::vector<uint32_t>> cells_of(kChunk);
  std::vector<uint32_t> touched;  // indices in `active` with arrivals in this chunk
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
    touched.clear();
    for (size_t i = 0; i < m; ++i) {
      for (uint32_t c : cells_of[i]) {
        if (active_of[c] < 0) {
          active_of[c] = int32_t(active.size());
          active.push_back({c, RayCache(RayCacheOptions{r_min, c}), {}, {}});
        }
        CellCache& cc = active[size_t(active_of[c])];
        if (cc.arrived.empty()) touched.push_back(uint32_t(active_of[c]));
        cc.arrived.push_back(uint32_t(begin + i));
      }
    }
    // "As rays are generated, they are added to the cache" (sec. 5.3), each chunk's arrivals in
    // a random order; whenever the cache is full its fullest bucket goes to the GPU.
    for (uint32_t a : touched) {
      CellCache& cc = active[a];
      for (size_t k = 0; k < cc.arrived.size();) {
        const size_t take = std::min(cc.arrived.size() - k, size_t(capacity) - cc.cache.size());
        const std::span<const uint32_t> part(cc.arrived.data() + k, take);
        cc.cache.insert(rays, part);
        cc.ray_of.insert(cc.ray_of.end(), part.begin(), part.end());
        k += take;
        while (cc.cache.size() >= capacity) PENUMBRA_TRY(submitBucket(cc));
      }
      cc.arrived.clear();
    }
    collectReady();
  }
  // The ray tracer needs a result: full buckets go to the GPU, the short remainder of each
  // cache is forced to the CPU (sec. 6.2) while the GPU finishes.
  std::vector<std::pair<uint32_t, uint32_t>> forced;  // (ray, cell)
  for (CellCache& cc : active) {
    while (cc.cache.size() >= r_min) PENUMBRA_TRY(submitBucket(cc));
    cc.cache.nextBucket(bucket);
    for (uint32_t id : bucket) forced.emplace_back(cc.ray_of[id], cc.cell);
    collectReady();
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
