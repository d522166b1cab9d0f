#version 450
// The receiver pass (Wallner sec. 3 and 3.1): every receiver triangle rendered orthographically
// into the atlas through its lightmap UVs, once as a polygon and once as its outline (the same
// draw with glPolygonMode GL_LINE, line width 1), so that the texel centres lying exactly on the
// triangle's edges, which polygon rasterisation may leave out, are produced by the lines. UV
// (0, 0) is the top-left corner of the atlas image (row 0 at the top, lightmap_atlas.h): window
// y = v * height addresses row v * height of the texture as stored, so no flip is needed.
#include "radiosity/progressive_layout.glsl"

layout(std430, binding = 0) readonly buffer Triangles { GpuProgressiveTriangle triangles[]; };
layout(std430, binding = 1) readonly buffer Receivers { uint receivers[]; };

uniform uint receiver_first;  // this pass's receivers: receivers[receiver_first ..]

flat out uint v_triangle;

void main() {
  const uint t = receivers[receiver_first + uint(gl_VertexID) / 3u];
  const vec2 uv = triangles[t].uv[uint(gl_VertexID) % 3u];
  v_triangle = t;
  gl_Position = vec4(uv * 2.0 - 1.0, 0.0, 1.0);
}
