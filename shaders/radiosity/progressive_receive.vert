#version 450
#include "radiosity/progressive_bindings.glsl"
// The receiver pass (Wallner sec. 3): every receiver element drawn into the atlas as a point of
// size 1 at its texel's centre, so that each element gets exactly one fragment. (The paper
// rasterises each receiver triangle through its lightmap UVs, with outlines for the texels on
// its edges; the value a fragment computes depends only on its texel's element, so one fragment
// per element is the same result without double counting or missed texels.) UV (0, 0) is the
// top-left corner of the atlas image (row 0 at the top, chart_atlas.h): window y = row, so no
// flip is needed.
#include "radiosity/progressive_layout.glsl"

// The receivers (Wallner sec. 4, radiosity/progressive_receivers.h): the elements themselves, or
// clusters of them, each written at the texel of its element nearest its point.
layout(std430, binding = PROGRESSIVE_SSBO_RECEIVERS) readonly buffer Receivers { GpuProgressiveElement receivers[]; };

uniform int atlas_width;
uniform int atlas_height;

flat out uint v_element;

void main() {
  const uint e = uint(gl_VertexID);  // glDrawArrays' first is included
  const uint texel = receivers[e].texel;
  const vec2 centre = vec2(float(texel % uint(atlas_width)) + 0.5,
                           float(texel / uint(atlas_width)) + 0.5);
  v_element = e;
  gl_Position = vec4(centre / vec2(float(atlas_width), float(atlas_height)) * 2.0 - 1.0, 0.0, 1.0);
}
