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
      if (cpu_.isa() != CpuIsa::kScalar) {
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

namespace {

// A GPU job in flight and the rays it carries.
struct Pending {
  GlRasterKernel::Job job;
  std::vector<uint32_t> rays;
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

}  // namespace

// One intersect() call: the nearest hit so far per ray, the GPU jobs in flight and the caches
// of the cells rays entered.
class HybridRayEngine::Batch {
 public:
  static constexpr size_t kChunk = 4096;

  Batch(const HybridRayEngine& engine, const RayBatch& rays, HybridStats* stats)
      : engine_(engine),
        rays_(rays),
        stats_(stats),
        best_(rays.size()),
        out_(size_t(engine.gpu_.tile()) * size_t(engine.gpu_.tile())),
        active_of_(engine.cells_.size(), -1),
        cells_of_(kChunk) {
    local_.gpu_cells = engine.cells_.size();
  }

  // CPU: traverse, intersecting non-cell leaves, noting the cells each ray enters.
  void traverseChunk(size_t begin, size_t m) {
    parallelRange(m, 64, [&](size_t b, size_t e) {
      for (size_t i = b; i < e; ++i) {
        cells_of_[i].clear();
        Hit h;
        engine_.traverse(0, rays_.get(begin + i), h, &cells_of_[i]);
        best_[begin + i] = h;
      }
    });
  }

  // The chunk's rays as arrivals at the caches of the cells they entered, in order.
  void noteArrivals(size_t begin, size_t m) {
    touched_.clear();
    for (size_t i = 0; i < m; ++i) {
      for (uint32_t c : cells_of_[i]) {
        if (active_of_[c] < 0) {
          active_of_[c] = int32_t(active_.size());
          active_.push_back({c, RayCache(RayCacheOptions{engine_.options_.r_min, c}), {}, {}});
        }
        CellCache& cc = active_[size_t(active_of_[c])];
        if (cc.arrived.empty()) touched_.push_back(uint32_t(active_of_[c]));
        cc.arrived.push_back(uint32_t(begin + i));
      }
    }
  }

  // "As rays are generated, they are added to the cache" (sec. 5.3), each chunk's arrivals in
  // a random order; whenever the cache is full its fullest bucket goes to the GPU.
  Status cacheArrivals() {
    const uint32_t capacity = engine_.options_.cache_rays;
    for (uint32_t a : touched_) {
      CellCache& cc = active_[a];
      for (size_t k = 0; k < cc.arrived.size();) {
        const size_t take = std::min(cc.arrived.size() - k, size_t(capacity) - cc.cache.size());
        const std::span<const uint32_t> part(cc.arrived.data() + k, take);
        cc.cache.insert(rays_, part);
        cc.ray_of.insert(cc.ray_of.end(), part.begin(), part.end());
        k += take;
        while (cc.cache.size() >= capacity) PENUMBRA_TRY(submitBucket(cc));
      }
      cc.arrived.clear();
    }
    return {};
  }

  // Collect what the GPU has finished, without waiting.
  void collectReady() {
    while (!pending_.empty() && GlRasterKernel::ready(pending_.front().job)) {
      collectOne(pending_.front());
      pending_.pop_front();
    }
  }

  // The ray tracer needs a result: full buckets go to the GPU, the short remainder of each
  // cache is forced to the CPU (sec. 6.2) while the GPU finishes.
  Status drain() {
    std::vector<std::pair<uint32_t, uint32_t>> forced;  // (ray, cell)
    for (CellCache& cc : active_) {
      while (cc.cache.size() >= engine_.options_.r_min) PENUMBRA_TRY(submitBucket(cc));
      cc.cache.nextBucket(bucket_);
      for (uint32_t id : bucket_) forced.emplace_back(cc.ray_of[id], cc.cell);
      collectReady();
    }
    local_.forced_ray_cells = forced.size();
    std::vector<Hit> forced_hits(forced.size());
    parallelRange(forced.size(), 64, [&](size_t b, size_t e) {
      for (size_t i = b; i < e; ++i) {
        Hit h;
        engine_.traverse(engine_.cells_[forced[i].second].node, rays_.get(forced[i].first), h,
                         nullptr);
        forced_hits[i] = h;
      }
    });
    for (size_t i = 0; i < forced.size(); ++i) keepNearest(best_[forced[i].first], forced_hits[i]);
    for (Pending& p : pending_) collectOne(p);
    return {};
  }

  void write(HitBatch& hits) const {
    hits.resize(rays_.size());
    for (size_t i = 0; i < rays_.size(); ++i) hits.set(i, best_[i]);
    if (stats_) *stats_ = local_;
  }

 private:
  void collectOne(Pending& p) {
    engine_.gpu_.collect(p.job, out_.data());
    for (size_t k = 0; k < p.rays.size(); ++k) keepNearest(best_[p.rays[k]], out_[k]);
    spare_.push_back(std::move(p.rays));
  }

  // Takes the cache's fullest bucket (exactly R_min rays) to the GPU with the cell's triangles.
  Status submitBucket(CellCache& cc) {
    const uint32_t r_min = engine_.options_.r_min;
    cc.cache.nextBucket(bucket_);
    PENUMBRA_CHECK(bucket_.size() == r_min);
    std::vector<uint32_t> ray_indices;
    if (!spare_.empty()) {
      ray_indices = std::move(spare_.back());
      spare_.pop_back();
    }
    ray_indices.clear();
    for (uint32_t id : bucket_) ray_indices.push_back(cc.ray_of[id]);
    const Cell& cell = engine_.cells_[cc.cell];
    Expected<GlRasterKernel::Job> job =
        engine_.gpu_.submit(rays_, ray_indices, cell.first, cell.count);
    if (!job) return job.error();
    if (stats_) {
      local_.gpu_triangles += cell.count;
      local_.gpu_triangles_culled +=
          engine_.gpu_.culledTriangles(job->bound, cell.first, cell.count);
    }
    pending_.push_back({std::move(*job), std::move(ray_indices)});
    ++local_.gpu_batches;
    local_.gpu_ray_cells += r_min;
    return {};
  }

  const HybridRayEngine& engine_;
  const RayBatch& rays_;
  HybridStats* stats_;
  HybridStats local_;
  std::vector<Hit> best_;
  std::deque<Pending> pending_;
  std::vector<std::vector<uint32_t>> spare_;  // ray lists of collected jobs, for reuse
  std::vector<Hit> out_;
  std::vector<CellCache> active_;
  std::vector<int32_t> active_of_;  // cell -> index in `active_`
  std::vector<uint32_t> bucket_;
  std::vector<std::vector<uint32_t>> cells_of_;  // per ray of the chunk: the cells it entered
  std::vector<uint32_t> touched_;                // indices in `active_` with arrivals in this chunk
};

Status HybridRayEngine::intersect(const RayBatch& rays, HitBatch& hits, HybridStats* stats) const {
  const size_t n = rays.size();
  Batch batch(*this, rays, stats);
  for (size_t begin = 0; begin < n; begin += Batch::kChunk) {
    const size_t m = std::min(Batch::kChunk, n - begin);
    batch.traverseChunk(begin, m);
    batch.noteArrivals(begin, m);
    PENUMBRA_TRY(batch.cacheArrivals());
    batch.collectReady();
  }
  PENUMBRA_TRY(batch.drain());
  batch.write(hits);
  return {};
}

}  // namespace penumbra
