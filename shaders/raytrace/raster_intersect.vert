#version 450
#include "raytrace/bindings.glsl"
// The Ray Engine's GPU kernel (Carr, Hall, Hart 2002, sec. 3.3-4.2): each triangle is broadcast
// to every ray as the attributes of a screen-filling quad. One instance per triangle, in triangle
// order; the quad's four corners come from gl_VertexID (triangle strip). The ray-independent
// vectors of eq. 1-8 (n, ab, ac, bc) are computed here, once per triangle, as the paper does in
// its vertex stage.
//
// Culling (sec. 5.3: the vertex shader culls "triangles outside the ray bucket ... it can
// transform the screen-filling quad containing the triangle data to an offscreen location which
// causes it to be clipped"): a triangle whose bounding box no ray of this pass can reach
// (bucketMayReach, the conservative bound of kernels/bucket_cull.h) gets its quad moved to
// x in [3, 5], outside the clip volume, so no fragment runs for it.
#include "common/bucket_cull.glsl"
#include "raytrace/layout.glsl"

layout(std430, binding = RAY_ENGINE_SSBO_TRIANGLES) readonly buffer Triangles {
  GpuTriangle triangles[];
};

uniform uint first_triangle;
uniform RayBucketBound bucket;  // this pass's rays

flat out vec3 v_a;
flat out vec3 v_b;
flat out vec3 v_n;
flat out vec3 v_ab;
flat out vec3 v_ac;
flat out vec3 v_bc;
flat out int v_id;

void main() {
  GpuTriangle tri = triangles[first_triangle + uint(gl_InstanceID)];
  v_a = tri.p0;
  v_b = tri.p1;
  v_ab = tri.p1 - tri.p0;
  v_ac = tri.p2 - tri.p0;
  v_bc = tri.p2 - tri.p1;
  v_n = cross(v_ab, v_ac);
  v_id = tri.id;
  vec2 corner = vec2(float(gl_VertexID & 1), float(gl_VertexID >> 1));
  vec3 lo = min(min(tri.p0, tri.p1), tri.p2), hi = max(max(tri.p0, tri.p1), tri.p2);
  float offscreen = bucketMayReach(bucket, lo, hi) ? 0.0 : 4.0;
  gl_Position = vec4(corner * 2.0 - 1.0 + vec2(offscreen, 0.0), 0.0, 1.0);
}
