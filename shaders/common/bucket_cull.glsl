// Culling triangles outside a ray bucket (Carr, Hall, Hart 2002, sec. 5.3): the GLSL twin of
// bucketMayReach in src/penumbra/kernels/bucket_cull.h, which documents the bound and why the
// test is conservative. Same operations in the same order; change both together
// (BucketCull.GlslTwinAgreesWithCpp checks that they agree). `precise` forbids fused
// multiply-adds, which the C++ side does not use either (-ffp-contract=off).

// RayBucketBound, set by setBucketBoundUniforms (ray_engine_gl.h). The beam's two faces are
// p_a = reach_lo[axis] and p_a = reach_hi[axis].
struct RayBucketBound {
  vec3 reach_lo, reach_hi;  // box of the rays' chords in the clip box
  vec3 q0_lo, q0_hi;        // where the lines cross the first face (b != axis)
  vec3 q1_lo, q1_hi;        // and the second
  int mode;                 // BucketCullMode: 0 keep all, 1 box, 2 box and beam, 3 cull all
  int axis;
  float inv_length;  // 1 / (reach_hi[axis] - reach_lo[axis])
};

// Can some ray of the bucket reach a point of the box [lo, hi]? False: cull the triangle.
bool bucketMayReach(RayBucketBound b, vec3 lo, vec3 hi) {
  if (b.mode == 0) return true;
  if (b.mode == 3) return false;
  // The reach box.
  if (any(greaterThan(lo, b.reach_hi)) || any(lessThan(hi, b.reach_lo))) return false;
  if (b.mode != 2) return true;
  // The beam: s at the two ends of the part of the box inside the reach box.
  int a = b.axis;
  precise float s0 = clamp((max(lo[a], b.reach_lo[a]) - b.reach_lo[a]) * b.inv_length, 0.0, 1.0);
  precise float s1 = clamp((min(hi[a], b.reach_hi[a]) - b.reach_lo[a]) * b.inv_length, 0.0, 1.0);
  for (int k = 0; k < 3; ++k) {
    if (k == a) continue;
    // The hull of (1 - s) [q0_lo, q0_hi] + s [q1_lo, q1_hi] for s in [s0, s1].
    precise float lo_dq = b.q1_lo[k] - b.q0_lo[k];
    precise float hi_dq = b.q1_hi[k] - b.q0_hi[k];
    precise float beam_lo = min(b.q0_lo[k] + s0 * lo_dq, b.q0_lo[k] + s1 * lo_dq);
    precise float beam_hi = max(b.q0_hi[k] + s0 * hi_dq, b.q0_hi[k] + s1 * hi_dq);
    if (beam_lo > min(hi[k], b.reach_hi[k]) || beam_hi < max(lo[k], b.reach_lo[k])) {
      return false;
    }
  }
  return true;
}
