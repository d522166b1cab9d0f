#include "penumbra/raytrace/cpu_packet.h"

#include "penumbra/accel/bvh.h"
#include "penumbra/kernels/ray_triangle.h"
#include "penumbra/raytrace/cpu_simd.h"
#include "penumbra/raytrace/ray_engine.h"

#include <cmath>
#include <cstring>
#include <limits>

namespace penumbra {

bool packetTracingAvailable() {
  return cpuHasAvx2();
}

bool packetEligible(const RayBatch& rays, size_t first) {
  if (first + kPacketSize > rays.size()) return false;
  // Same octant (sign bits) and same dominant axis give the same axis permutation in the
  // watertight test; directions within acos(0.9) of the first: dot^2 >= 0.81 |d|^2 |d0|^2.
  const float x0 = rays.dx[first], y0 = rays.dy[first], z0 = rays.dz[first];
  const auto major = [](float x, float y, float z) {
    const float ax = std::fabs(x), ay = std::fabs(y), az = std::fabs(z);
    return (ax > ay) ? (ax > az ? 0 : 2) : (ay > az ? 1 : 2);
  };
  const int axis0 = major(x0, y0, z0);
  const float len0 = x0 * x0 + y0 * y0 + z0 * z0;
  for (int k = 0; k < kPacketSize; ++k) {
    const size_t i = first + size_t(k);
    const float x = rays.dx[i], y = rays.dy[i], z = rays.dz[i];
    if (!(rays.tmin[i] <= rays.tmax[i])) return false;
    if (std::signbit(x) != std::signbit(x0) || std::signbit(y) != std::signbit(y0) ||
        std::signbit(z) != std::signbit(z0) || major(x, y, z) != axis0) {
      return false;
    }
    const float dot = x * x0 + y * y0 + z * z0;
    if (!(dot > 0.0f) || dot * dot < 0.81f * (x * x + y * y + z * z) * len0) return false;
  }
  return true;
}

#if PENUMBRA_HAVE_AVX2_KERNELS

namespace {

struct Packet {
  __m256 o[3];    // origins by axis
  __m256 inv[3];  // safe reciprocal directions
  __m256 tmin, tmax;
  bool neg[3];  // the common direction signs
  // Watertight constants: common axis permutation, per-ray shear.
  int kx, ky, kz;
  __m256 sx, sy, sz;
};

struct PacketHits {
  __m256i id;
  __m256 t, u, v;
};

PENUMBRA_AVX2_TARGET inline __m256 loadLanes(const LargeVector<float>& v, size_t first) {
  return _mm256_loadu_ps(v.data() + first);
}

// One triangle against the packet, the watertight test of kernels/ray_triangle.h across rays.
PENUMBRA_AVX2_TARGET inline void trianglePacket(const Packet& p, const TriangleBlock8& b, int lane,
                                                __m256 active, PacketHits& h, __m256& tmax,
                                                const RayBatch& rays, size_t first) {
  const float* pv[3][3];
  for (int k = 0; k < 3; ++k) {
    for (int a = 0; a < 3; ++a) pv[k][a] = &b.v[k][a][lane];
  }
  __m256 px[3], py[3], pz[3];
  for (int k = 0; k < 3; ++k) {
    const __m256 rx = _mm256_sub_ps(_mm256_set1_ps(*pv[k][p.kx]), p.o[p.kx]);
    const __m256 ry = _mm256_sub_ps(_mm256_set1_ps(*pv[k][p.ky]), p.o[p.ky]);
    const __m256 rz = _mm256_sub_ps(_mm256_set1_ps(*pv[k][p.kz]), p.o[p.kz]);
    px[k] = _mm256_sub_ps(rx, _mm256_mul_ps(p.sx, rz));
    py[k] = _mm256_sub_ps(ry, _mm256_mul_ps(p.sy, rz));
    pz[k] = rz;
  }
  const WatertightLanes lanes = watertightLanes(px, py, pz, p.sz, p.tmin, tmax);
  const int on_edge = int(lanes.on_edge) & _mm256_movemask_ps(active);
  __m256 t = lanes.t, uu = lanes.u, vv = lanes.v;
  __m256 ok = _mm256_and_ps(lanes.ok, active);
  if (on_edge) {
    // Exactly on an edge: the scalar test, which re-evaluates in double.
    alignas(32) float tl[8], ul[8], vl[8], okl[8], tmaxl[8];
    _mm256_store_ps(tl, t);
    _mm256_store_ps(ul, uu);
    _mm256_store_ps(vl, vv);
    _mm256_store_ps(okl, ok);
    _mm256_store_ps(tmaxl, tmax);
    const glm::vec3 p0(b.v[0][0][lane], b.v[0][1][lane], b.v[0][2][lane]);
    const glm::vec3 p1(b.v[1][0][lane], b.v[1][1][lane], b.v[1][2][lane]);
    const glm::vec3 p2(b.v[2][0][lane], b.v[2][1][lane], b.v[2][2][lane]);
    for (int k = 0; k < 8; ++k) {
      if (!(on_edge >> k & 1)) continue;
      const Ray r = rays.get(first + size_t(k));
      const WatertightRay wr = makeWatertightRay(r.origin, r.dir);
      float ts, us, vs;
      const bool hit = intersectTriangle(wr, p0, p1, p2, r.tmin, tmaxl[k], ts, us, vs);
      uint32_t bits = hit ? 0xFFFFFFFFu : 0u;
      std::memcpy(&okl[k], &bits, 4);
      if (hit) tl[k] = ts, ul[k] = us, vl[k] = vs;
    }
    t = _mm256_load_ps(tl);
    uu = _mm256_load_ps(ul);
    vv = _mm256_load_ps(vl);
    ok = _mm256_load_ps(okl);
  }
  if (_mm256_movemask_ps(ok) == 0) return;
  // Closest hit; exact ties to the lower triangle id.
  const __m256i id = _mm256_set1_epi32(b.id[lane]);
  const __m256i none = _mm256_cmpgt_epi32(_mm256_setzero_si256(), h.id);  // id < 0
  const __m256i lower = _mm256_cmpgt_epi32(h.id, id);
  const __m256 tie = _mm256_and_ps(_mm256_cmp_ps(t, tmax, _CMP_EQ_OQ),
                                   _mm256_castsi256_ps(_mm256_or_si256(none, lower)));
  const __m256 take = _mm256_and_ps(ok, _mm256_or_ps(_mm256_cmp_ps(t, tmax, _CMP_LT_OQ), tie));
  h.t = _mm256_blendv_ps(h.t, t, take);
  h.u = _mm256_blendv_ps(h.u, uu, take);
  h.v = _mm256_blendv_ps(h.v, vv, take);
  h.id = _mm256_castps_si256(
      _mm256_blendv_ps(_mm256_castsi256_ps(h.id), _mm256_castsi256_ps(id), take));
  tmax = _mm256_blendv_ps(tmax, t, take);
}

// The packet of rays [first, first + 8): origins, safe reciprocal directions and their common
// signs, and the watertight test's common axis permutation (the first ray's) with each ray's
// shear.
[[gnu::always_inline]] PENUMBRA_AVX2_TARGET inline Packet makePacket(const RayBatch& rays,
                                                                     size_t first) {
  Packet p;
  p.o[0] = loadLanes(rays.ox, first);
  p.o[1] = loadLanes(rays.oy, first);
  p.o[2] = loadLanes(rays.oz, first);
  alignas(32) float inv[3][8], sx[8], sy[8], sz[8];
  WatertightRay w0{};
  for (int k = 0; k < 8; ++k) {
    const Ray r = rays.get(first + size_t(k));
    for (int a = 0; a < 3; ++a) inv[a][k] = safeReciprocal(r.dir[a]);
    const WatertightRay w = makeWatertightRay(r.origin, r.dir);
    sx[k] = w.sx, sy[k] = w.sy, sz[k] = w.sz;
    if (k == 0) w0 = w;
  }
  for (int a = 0; a < 3; ++a) {
    p.inv[a] = _mm256_load_ps(inv[a]);
    p.neg[a] = inv[a][0] < 0.0f;
  }
  p.kx = w0.kx, p.ky = w0.ky, p.kz = w0.kz;
  p.sx = _mm256_load_ps(sx);
  p.sy = _mm256_load_ps(sy);
  p.sz = _mm256_load_ps(sz);
  p.tmin = loadLanes(rays.tmin, first);
  return p;
}

// A child entered, with the lanes that entered it and their entry distances: a popped entry is
// culled lane by lane against the hits found since.
struct alignas(32) PacketEntry {
  __m256 mask, t_entry;
  int32_t ref;
};

// A leaf's triangles against the packet's lanes in `mask`.
[[gnu::always_inline]] PENUMBRA_AVX2_TARGET inline void packetLeaf(
    const RayEngine& engine, int32_t ref, const Packet& p, __m256 mask, PacketHits& h, __m256& tmax,
    const RayBatch& rays, size_t first) {
  if (ref == Bvh8Node::kEmpty) return;
  const TriangleBlock8& block = engine.blocks()[bvh8LeafIndex(ref)];
  const uint32_t count = bvh8LeafCount(ref);
  for (uint32_t lane = 0; lane < count; ++lane) {
    trianglePacket(p, block, int(lane), mask, h, tmax, rays, first);
  }
}

// A node's children tested against all eight rays (the lanes in `mask`): the children entered
// go on the stack but the nearest, judged by their nearest lane's entry, which becomes `ref`
// with its lanes in `mask`. False when none is entered.
// The children's near and far planes of a node for the packet's direction signs: dequantised as
// the single-ray test does (origin + q * scale), or a float node's own.
struct PacketPlanes {
  alignas(32) float store[2][3][8];
  const float* near_plane[3];
  const float* far_plane[3];
  uint32_t valid;
};

PENUMBRA_AVX2_TARGET inline void packetPlanes(const Bvh8QNode& n, const Packet& p,
                                              PacketPlanes& out) {
  const uint8_t* lo[3] = {n.lo_x, n.lo_y, n.lo_z};
  const uint8_t* hi[3] = {n.hi_x, n.hi_y, n.hi_z};
  for (int a = 0; a < 3; ++a) {
    _mm256_store_ps(out.store[0][a],
                    BoxTester::planeAvx2(p.neg[a] ? hi[a] : lo[a], n.origin[a], n.scale[a]));
    _mm256_store_ps(out.store[1][a],
                    BoxTester::planeAvx2(p.neg[a] ? lo[a] : hi[a], n.origin[a], n.scale[a]));
    out.near_plane[a] = out.store[0][a];
    out.far_plane[a] = out.store[1][a];
  }
  out.valid = n.valid;
}

PENUMBRA_AVX2_TARGET inline void packetPlanes(const Bvh8Node& n, const Packet& p,
                                              PacketPlanes& out) {
  const float* lo[3] = {n.lo_x, n.lo_y, n.lo_z};
  const float* hi[3] = {n.hi_x, n.hi_y, n.hi_z};
  out.valid = 0;
  for (int a = 0; a < 3; ++a) {
    out.near_plane[a] = p.neg[a] ? hi[a] : lo[a];
    out.far_plane[a] = p.neg[a] ? lo[a] : hi[a];
  }
  for (int i = 0; i < 8; ++i) out.valid |= uint32_t(n.child[i] != Bvh8Node::kEmpty) << i;
}

template <typename Node>
[[gnu::always_inline]] PENUMBRA_AVX2_TARGET inline bool packetChildren(const RayEngine& engine,
                                                                       const Node& n,
                                                                       const Packet& p, __m256 tmax,
                                                                       PacketEntry* stack, int& sp,
                                                                       int32_t& ref, __m256& mask) {
  const __m256 inf = _mm256_set1_ps(std::numeric_limits<float>::infinity());
  PacketPlanes planes;
  packetPlanes(n, p, planes);
  const float* const* near_plane = planes.near_plane;
  const float* const* far_plane = planes.far_plane;
  int entered = 0;
  int32_t child_ref[8];
  __m256 child_mask[8], child_t[8];
  float key[8];
  for (uint32_t valid = planes.valid; valid; valid &= valid - 1) {
    const int c = __builtin_ctz(valid);
    __m256 tn = p.tmin, tf = tmax;
    for (int a = 0; a < 3; ++a) {
      tn = _mm256_max_ps(
          tn, _mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps(near_plane[a][c]), p.o[a]), p.inv[a]));
      tf = _mm256_min_ps(
          tf, _mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps(far_plane[a][c]), p.o[a]), p.inv[a]));
    }
    tf = _mm256_mul_ps(tf, _mm256_set1_ps(kFarScale));
    const __m256 m = _mm256_and_ps(mask, _mm256_cmp_ps(tn, tf, _CMP_LE_OQ));
    if (_mm256_movemask_ps(m) == 0) continue;
    // The nearest entry among the lanes that enter.
    __m256 t = _mm256_blendv_ps(inf, tn, m);
    t = _mm256_min_ps(t, _mm256_permute_ps(t, 0b10110001));
    t = _mm256_min_ps(t, _mm256_permute_ps(t, 0b01001110));
    t = _mm256_min_ps(t, _mm256_permute2f128_ps(t, t, 1));
    // Insertion by key, farthest first.
    const float k = _mm256_cvtss_f32(t);
    int j = entered++;
    while (j > 0 && key[j - 1] < k) {
      key[j] = key[j - 1], child_ref[j] = child_ref[j - 1];
      child_mask[j] = child_mask[j - 1], child_t[j] = child_t[j - 1];
      --j;
    }
    key[j] = k, child_ref[j] = n.child[c], child_mask[j] = m, child_t[j] = tn;
  }
  if (entered == 0) return false;
  for (int j = 0; j < entered; ++j) engine.prefetchChild(child_ref[j]);
  for (int j = 0; j < entered - 1; ++j) {
    stack[sp++] = PacketEntry{child_mask[j], child_t[j], child_ref[j]};
  }
  ref = child_ref[entered - 1];
  mask = child_mask[entered - 1];
  return true;
}

// The next entry with a lane still entering before its hit (its reference and lanes into `ref`
// and `mask`); false when the stack runs out.
[[gnu::always_inline]] PENUMBRA_AVX2_TARGET inline bool popPacketEntry(const PacketEntry* stack,
                                                                       int& sp, __m256 tmax,
                                                                       int32_t& ref, __m256& mask) {
  while (sp > 0) {
    --sp;
    mask = _mm256_and_ps(stack[sp].mask, _mm256_cmp_ps(stack[sp].t_entry, tmax, _CMP_LE_OQ));
    if (_mm256_movemask_ps(mask) != 0) {
      ref = stack[sp].ref;
      return true;
    }
  }
  return false;
}

// The packet's hits to hits[first, first + 8).
[[gnu::always_inline]] PENUMBRA_AVX2_TARGET inline void storePacketHits(const PacketHits& h,
                                                                        size_t first,
                                                                        HitBatch& hits) {
  alignas(32) int32_t id[8];
  alignas(32) float t[8], u[8], v[8];
  _mm256_store_si256(reinterpret_cast<__m256i*>(id), h.id);
  _mm256_store_ps(t, h.t);
  _mm256_store_ps(u, h.u);
  _mm256_store_ps(v, h.v);
  for (int k = 0; k < 8; ++k) {
    hits.set(first + size_t(k), id[k] >= 0 ? Hit{id[k], t[k], u[k], v[k]} : Hit{});
  }
}

template <typename Node>
PENUMBRA_AVX2_TARGET void tracePacketIn(const RayEngine& engine, const LargeVector<Node>& nodes,
                                        const RayBatch& rays, size_t first, HitBatch& hits) {
  const Packet p = makePacket(rays, first);
  __m256 tmax = loadLanes(rays.tmax, first);

  PacketHits h{_mm256_set1_epi32(-1), _mm256_setzero_ps(), _mm256_setzero_ps(),
               _mm256_setzero_ps()};
  // The wide tree the single rays walk (accel/wide_bvh.h). A node's children are
  // tested against all eight rays; each child entered goes with the lanes that entered it and
  // their entry distances, so a popped entry is culled lane by lane against the hits found
  // since. Children are visited nearest first, judged by their nearest lane's entry.
  PacketEntry stack[kMaxBvhDepth * 7 + 8];
  int sp = 0;
  int32_t ref = engine.wideRoot();
  __m256 mask = _mm256_cmp_ps(p.tmin, tmax, _CMP_LE_OQ);
  for (;;) {
    if (bvh8IsLeaf(ref)) {
      packetLeaf(engine, ref, p, mask, h, tmax, rays, first);
    } else if (packetChildren(engine, nodes[size_t(ref)], p, tmax, stack, sp, ref, mask)) {
      continue;
    }
    if (!popPacketEntry(stack, sp, tmax, ref, mask)) break;
  }
  storePacketHits(h, first, hits);
}

}  // namespace

PENUMBRA_AVX2_TARGET void tracePacket(const RayEngine& engine, const RayBatch& rays, size_t first,
                                      HitBatch& hits) {
  if (engine.isa() == CpuIsa::kAvx512) {
    tracePacketIn(engine, engine.floatNodes(), rays, first, hits);
  } else {
    tracePacketIn(engine, engine.quantisedNodes(), rays, first, hits);
  }
}

#else

void tracePacket(const RayEngine&, const RayBatch&, size_t, HitBatch&) {}

#endif

}  // namespace penumbra
