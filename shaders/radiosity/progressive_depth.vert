#version 450
#include "radiosity/progressive_bindings.glsl"
// Visibility from a batch of shooter points (Wallner sec. 3, Algorithm 1): the scene rendered
// through each point's hemispherical stereographic projection into its tile of a shared depth
// texture, the linear depth computed here, in the vertex stage. One instance per point of the
// batch. Every triangle is drawn as its k x k sub-triangles clipped against the shooter's plane
// (progressive_hemisphere.glsl; the paper culls triangles behind the plane): six vertices per
// sub-triangle, the fan (0, 1, 2), (0, 2, 3) of its clipped piece; a fan triangle the piece does
// not have collapses to a point outside the view and produces no fragment. The images lie in
// the unit disc; clip distances keep rounding from spilling into a neighbouring tile.
#include "radiosity/progressive_layout.glsl"
#include "radiosity/progressive_hemisphere.glsl"

layout(std430, binding = PROGRESSIVE_SSBO_TRIANGLES) readonly buffer Triangles { GpuProgressiveTriangle triangles[]; };
// Per sub-triangle: (triangle, sub-triangle code).
layout(std430, binding = PROGRESSIVE_SSBO_SUB_TRIANGLES) readonly buffer SubTriangles { uvec2 sub_triangles[]; };
#ifndef MAX_BATCH_POINTS
#error "MAX_BATCH_POINTS comes from the host (radiosity/hemisphere_gl.h: batchPointDefines)"
#endif
layout(std140, binding = PROGRESSIVE_UBO_BATCH) uniform Batch { GpuBatchPoint batch[MAX_BATCH_POINTS]; };

uniform Hemisphere hemisphere;  // all but the origin, which is the batch's point
uniform uint tiles;             // tiles x tiles depth maps in the texture

out float gl_ClipDistance[4];
flat out uint v_triangle;
// For cut-outs (progressive_depth.frag): the barycentric parameters on the triangle, and the
// shooter point (the partly covering surfaces' hash).
out vec2 v_param;
flat out vec3 v_origin;

void main() {
  const uint sub = uint(gl_VertexID) / 6u, corner = uint(gl_VertexID) % 6u;
  const uint k = uint(gl_InstanceID);
  Hemisphere h = hemisphere;
  h.origin = batch[k].position_f.xyz + batch[k].eye.xyz;
  const uvec2 st = sub_triangles[sub];
  v_triangle = st.x;
  v_origin = h.origin;
  const ClippedPiece piece = clipSubTriangle(h, triangles[st.x], st.y);
  const int fan = int(corner / 3u);  // 0: (0, 1, 2), 1: (0, 2, 3)
  const int c = int(corner % 3u);
  const int index = c == 0 ? 0 : fan + c;
  v_param = piece.param[index];
  if (piece.count < 3 + fan) {
    gl_Position = vec4(0.0, 0.0, 2.0, 1.0);  // the same point for all three: no fragment
    for (int i = 0; i < 4; ++i) gl_ClipDistance[i] = -1.0;
    return;
  }
  const vec3 image = piece.image[index];
  gl_ClipDistance[0] = 1.0 + image.x;
  gl_ClipDistance[1] = 1.0 - image.x;
  gl_ClipDistance[2] = 1.0 + image.y;
  gl_ClipDistance[3] = 1.0 - image.y;
  const vec2 tex = (image.xy * 0.5 + 0.5 + tileOrigin(k, tiles)) / float(tiles);
  gl_Position = vec4(tex * 2.0 - 1.0, 2.0 * image.z - 1.0, 1.0);
}
