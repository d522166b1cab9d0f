// The CPU back end's AVX-512 inner loops, chosen at run time where the CPU has AVX-512 F, VL,
// BW and DQ (cpuHasAvx512); the AVX2 and scalar kernels of cpu_simd.h stay for the others. They
// give the same hits: the triangle test is the same watertight arithmetic, and the box test,
// though its rounding differs, is conservative like theirs (it may enter a child the exact test
// would skip, never skip one the ray enters), and ties between hits go to the lower triangle
// index whatever the order of the visit.
#pragma once

#include "penumbra/raytrace/cpu_simd.h"

#include <cmath>
#include <cstdint>

#if PENUMBRA_HAVE_AVX2_KERNELS
#define PENUMBRA_AVX512_TARGET \
  __attribute__((target("avx512f,avx512vl,avx512bw,avx512dq,avx2,fma,bmi,bmi2,popcnt,lzcnt")))
#endif

namespace penumbra {

// Whether this CPU runs the AVX-512 kernels (checked once, at run time).
inline bool cpuHasAvx512() {
#if PENUMBRA_HAVE_AVX2_KERNELS
  static const bool has = cpuHasAvx2() && __builtin_cpu_supports("avx512f") &&
                          __builtin_cpu_supports("avx512vl") &&
                          __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq");
  return has;
#else
  return false;
#endif
}

#if PENUMBRA_HAVE_AVX2_KERNELS
// Slab tests of one ray against the eight float child boxes of a node (Bvh8Node) in the fused
// form t = p inv - o inv: one FMA per plane with the plane read straight from the node, at
// offsets chosen once per ray by the direction's signs (the form of Embree's kernels), against
// sub-then-multiply for BoxTester.
//
// Rounding, with u = 2^-24. R = fl(o inv) is within u |R| of o inv, and the FMA rounds once, so
// a computed distance is within u |t| + u |R| of p inv - o inv, which is itself within u of the
// distance on the exact reciprocal. The absolute part is taken out in advance: near planes use
// R + e and far planes R - e, with e = 2^-21 |R| (8u |R|, which also covers the rounding of
// R +- e and of the far constants below). The relative part is covered by scaling every far
// distance by kFarScale512 = 1 + 2^-20 (16u; the two sides' relative errors add to under 8u):
// the far planes' reciprocal and constant, and tmax, come pre-multiplied by it, so the scale
// costs no instruction on the path from the node's load to the mask. Hence a child the exact
// slab test enters within [tmin, tmax] is always entered (Ize, "Robust BVH Ray Traversal",
// JCGT 2(2), 2013, for the form of the argument). An origin so far out that o inv overflows
// enters every box on that axis, which is conservative too.
inline constexpr float kFarScale512 = 1.0f + 0x1p-20f;

struct BoxTesterFloat {
  __m256 inv_near[3], c_near[3];     // per axis: inv, -(R + e)
  __m256 inv_far[3], c_far[3];       // per axis: inv s, -(R - e) s, s = kFarScale512
  uint32_t near_off[3], far_off[3];  // byte offsets of each axis's near and far planes in a node

  BoxTesterFloat() = default;
  PENUMBRA_AVX512_TARGET BoxTesterFloat(const glm::vec3& o, const glm::vec3& d) {
    const float invs[3] = {safeReciprocal(d.x), safeReciprocal(d.y), safeReciprocal(d.z)};
    const float orgs[3] = {o.x, o.y, o.z};
    for (int a = 0; a < 3; ++a) {
      const float r = orgs[a] * invs[a];
      const float e = std::fabs(r) * 0x1p-21f;
      float i_near = invs[a], i_far = invs[a] * kFarScale512;
      float cn = -(r + e), cf = -(r - e) * kFarScale512;
      if (!std::isfinite(cn) || !std::isfinite(cf) || !std::isfinite(i_far)) {
        i_near = i_far = 0.0f, cn = -INFINITY, cf = INFINITY;
      }
      inv_near[a] = _mm256_set1_ps(i_near);
      inv_far[a] = _mm256_set1_ps(i_far);
      c_near[a] = _mm256_set1_ps(cn);
      c_far[a] = _mm256_set1_ps(cf);
      // Bvh8Node: lo_x, hi_x, lo_y, hi_y, lo_z, hi_z, eight floats each.
      const uint32_t lo = uint32_t(a) * 64, hi = lo + 32;
      near_off[a] = invs[a] < 0.0f ? hi : lo;
      far_off[a] = invs[a] < 0.0f ? lo : hi;
    }
  }

  // The distances to eight planes at `p`: p inv + c, one rounding. (A member rather than a
  // lambda: lambdas do not take the enclosing function's target attribute.)
  PENUMBRA_AVX512_TARGET static __m256 plane(const char* p, __m256 inv, __m256 c) {
    return _mm256_fmadd_ps(_mm256_load_ps(reinterpret_cast<const float*>(p)), inv, c);
  }

  // Bit i is set when child i is entered within [tmin, tmax]; t_near gets the entry distances
  // (eight floats, 32-byte aligned).
  PENUMBRA_AVX512_TARGET uint32_t test(const Bvh8Node& n, float tmin, float tmax,
                                       float* t_near) const {
    const char* base = reinterpret_cast<const char*>(&n);
    const __m256 tn = _mm256_max_ps(
        _mm256_max_ps(plane(base + near_off[0], inv_near[0], c_near[0]),
                      plane(base + near_off[1], inv_near[1], c_near[1])),
        _mm256_max_ps(plane(base + near_off[2], inv_near[2], c_near[2]), _mm256_set1_ps(tmin)));
    const __m256 tf = _mm256_min_ps(_mm256_min_ps(plane(base + far_off[0], inv_far[0], c_far[0]),
                                                  plane(base + far_off[1], inv_far[1], c_far[1])),
                                    _mm256_min_ps(plane(base + far_off[2], inv_far[2], c_far[2]),
                                                  _mm256_set1_ps(tmax * kFarScale512)));
    _mm256_store_ps(t_near, tn);
    // Empty slots hold infinite planes (a NaN distance once a reciprocal is zeroed): masked out.
    const __mmask8 valid =
        _mm256_cmpneq_epi32_mask(_mm256_load_si256(reinterpret_cast<const __m256i*>(n.child)),
                                 _mm256_set1_epi32(Bvh8Node::kEmpty));
    return uint32_t(_mm256_mask_cmp_ps_mask(valid, tn, tf, _CMP_LE_OQ));
  }
};
#endif

}  // namespace penumbra
