#version 450
#include "subsurface/sss_bindings.glsl"
// Pass 2 of the subsurface method (Carr, Hall, Hart 2003, sec. 4.2.3, eq. 9) on the GPU:
// B_i = sum over element i's links of F max(0, E_node + G_node offset). The GPU twin of
// gatherScattered (src/penumbra/subsurface/sss_links.cpp), links in the same order.
#include "subsurface/sss_layout.glsl"

layout(local_size_x = 64) in;

layout(std430, binding = SSS_SSBO_LINKS) readonly buffer Links { GpuSssLink links[]; };
layout(std430, binding = SSS_SSBO_MEAN) readonly buffer Mean { vec4 mean[]; };
layout(std430, binding = SSS_SSBO_GRADIENT) readonly buffer Gradient { GpuMat3 gradient[]; };
layout(std430, binding = SSS_SSBO_SCATTERED) writeonly buffer Scattered { vec4 scattered[]; };

uniform uint element_count;
uniform uint links_per_element;

void main() {
  uint e = gl_GlobalInvocationID.x;
  if (e >= element_count) return;
  vec3 b = vec3(0.0);
  for (uint k = e * links_per_element; k < (e + 1u) * links_per_element; ++k) {
    GpuSssLink l = links[k];
    GpuMat3 g = gradient[l.node];
    vec3 value = mean[l.node].xyz + g.column[0].xyz * l.offset.x + g.column[1].xyz * l.offset.y +
                 g.column[2].xyz * l.offset.z;
    b += l.factor * max(value, vec3(0.0));
  }
  scattered[e] = vec4(b, 0.0);
}
