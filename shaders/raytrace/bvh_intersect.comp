#version 450
#include "raytrace/bindings.glsl"
// The Ray Engine's general GPU kernel: one invocation per ray traverses the binary BVH (the
// canonical tree of accel/bvh.h, uploaded as is) near child first, with the watertight test in
// the leaves; closest hit, exact ties to the lower triangle index, as on the CPU. With cut-outs
// (compiled with CUTOUT_SSBO_FIRST) a hit where the surface is a hole is passed over, as the
// CPU's hit filter does, with the same hash of the ray for partly covering surfaces.
#include "raytrace/layout.glsl"
#include "common/watertight.glsl"
#include "common/cutout.glsl"

layout(local_size_x = RAY_ENGINE_GROUP_SIZE) in;

layout(std430, binding = RAY_ENGINE_SSBO_NODES) readonly buffer Nodes { BvhNode nodes[]; };
layout(std430, binding = RAY_ENGINE_SSBO_TRIANGLES) readonly buffer Triangles { GpuTriangle triangles[]; };
layout(std430, binding = RAY_ENGINE_SSBO_RAYS) readonly buffer Rays { GpuRay rays[]; };
layout(std430, binding = RAY_ENGINE_SSBO_HITS) writeonly buffer Hits { GpuHit hits[]; };

uniform uint ray_count;
uniform uint any_hit;  // 1: stop at the first hit (occlusion)

const int kStackSize = MAX_BVH_DEPTH;  // accel/bvh.h kMaxBvhDepth, defined by ray_engine_gl.cpp

float safeReciprocal(float d) { return 1.0 / (abs(d) < 1e-30 ? (d < 0.0 ? -1e-30 : 1e-30) : d); }

// Slab test, far distance scaled by 1 + 2 gamma(3) (Ize 2013), as on the CPU.
bool hitBox(BvhNode n, vec3 org, vec3 inv, float tmin, float tmax, out float t_entry) {
  vec3 t0 = (n.lo - org) * inv;
  vec3 t1 = (n.hi - org) * inv;
  vec3 tn = min(t0, t1), tf = max(t0, t1);
  float a = max(max(tn.x, tn.y), max(tn.z, tmin));
  float b = min(min(tf.x, tf.y), min(tf.z, tmax)) * 1.0000004;
  t_entry = a;
  return a <= b;
}

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= ray_count) return;
  GpuRay ray = rays[i];
  GpuHit hit = GpuHit(-1, 1.0 / 0.0, 0.0, 0.0);
  float tmax = ray.tmax;
  bool found = false;
  if (ray.tmin <= ray.tmax && nodes.length() > 0) {
    WatertightRay wr = makeWatertightRay(ray.org, ray.dir);
    vec3 inv = vec3(safeReciprocal(ray.dir.x), safeReciprocal(ray.dir.y),
                    safeReciprocal(ray.dir.z));
    uint stack[kStackSize];
    int sp = 0;
    float t_root;
    uint node = 0u;
    bool alive = hitBox(nodes[0], ray.org, inv, ray.tmin, tmax, t_root);
    while (alive) {
      BvhNode n = nodes[node];
      if (n.count > 0u) {
        for (uint k = n.index; k < n.index + n.count; ++k) {
          GpuTriangle tri = triangles[k];
          float t, u, v;
          if (intersectTriangle(wr, tri.p0, tri.p1, tri.p2, ray.tmin, tmax, t, u, v)) {
#ifdef CUTOUTS
            const uint id = uint(tri.id);
            if (cutoutPossible(id) &&
                !cutoutStops(id, vec2(u, v), cutoutRayUniform(ray.org, ray.dir, id))) {
              continue;
            }
#endif
            if (t < tmax || (t == tmax && (!found || tri.id < hit.triangle))) {
              found = true;
              tmax = t;
              hit = GpuHit(tri.id, t, u, v);
            }
          }
        }
        if (found && any_hit != 0u) break;
      } else {
        float ta, tb;
        bool ha = hitBox(nodes[n.index], ray.org, inv, ray.tmin, tmax, ta);
        bool hb = hitBox(nodes[n.index + 1u], ray.org, inv, ray.tmin, tmax, tb);
        if (ha && hb) {
          bool a_first = ta <= tb;
          node = a_first ? n.index : n.index + 1u;
          stack[sp++] = a_first ? n.index + 1u : n.index;
          continue;
        }
        if (ha || hb) {
          node = ha ? n.index : n.index + 1u;
          continue;
        }
      }
      if (sp == 0) break;
      node = stack[--sp];
    }
  }
  hits[i] = hit;
}
