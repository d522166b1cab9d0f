#version 450
#include "subsurface/sss_bindings.glsl"
// The MIP-map of pass 1 up the link tree with its first-order term: per node the area-weighted
// mean of its children and the least-squares gradient of their means about it,
// G = S M^-1 with S = sum_c a_c (E_c - E_n) d_c^T. The GPU twin of mipMapIrradiance
// (src/penumbra/subsurface/sss_links.cpp). Nodes go in waves (a node's children all in earlier
// waves), one dispatch per wave; elements (wave 0) are pass 1's output.
#include "subsurface/sss_layout.glsl"

layout(local_size_x = 64) in;

layout(std430, binding = SSS_SSBO_NODES) readonly buffer Nodes { GpuSssNode nodes[]; };
layout(std430, binding = SSS_SSBO_CHILDREN) readonly buffer Children { uint children[]; };
layout(std430, binding = SSS_SSBO_WAVE_NODES) readonly buffer WaveNodes { uint wave_nodes[]; };
layout(std430, binding = SSS_SSBO_MEAN) buffer Mean { vec4 mean[]; };
layout(std430, binding = SSS_SSBO_GRADIENT) writeonly buffer Gradient { GpuMat3 gradient[]; };
layout(std430, binding = SSS_SSBO_MOMENT_INVERSE) readonly buffer MomentInverse {
  GpuMat3 moment_inverse[];
};

uniform uint wave_begin;
uniform uint wave_size;

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= wave_size) return;
  uint n = wave_nodes[wave_begin + i];
  GpuSssNode node = nodes[n];
  vec3 sum = vec3(0.0);
  for (uint k = node.child_first; k < node.child_first + node.child_count; ++k) {
    uint c = children[k];
    sum += mean[c].xyz * nodes[c].area;
  }
  vec3 m = node.area > 0.0 ? sum / node.area : vec3(0.0);
  mean[n] = vec4(m, 0.0);
  mat3 s = mat3(0.0);
  for (uint k = node.child_first; k < node.child_first + node.child_count; ++k) {
    uint c = children[k];
    vec3 d = nodes[c].position - node.position;
    s += nodes[c].area * outerProduct(mean[c].xyz - m, d);
  }
  GpuMat3 mi = moment_inverse[n];
  mat3 g = s * mat3(mi.column[0].xyz, mi.column[1].xyz, mi.column[2].xyz);
  gradient[n] = GpuMat3(vec4[3](vec4(g[0], 0.0), vec4(g[1], 0.0), vec4(g[2], 0.0)));
}
