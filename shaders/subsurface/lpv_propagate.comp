#version 450
#include "subsurface/lpv_bindings.glsl"
// One propagation step of subsurface light propagation volumes (Børlum et al. 2011, sec. 3.2
// and 4) on the GPU, the twin of lpvPropagate (src/penumbra/subsurface/lpv_volume.cpp): every
// cell of the object gathers from its six axial neighbours their coefficients times their
// transfer factors (absorption exp(-sigma dx), scattering (1 - s) + s g on band 1: sec. 3.2.1,
// eq. 3) through the propagation matrices' six non-zero entries; the other cells are set to
// zero. After the first `skip_steps` steps (sec. 4) the step's result is added to the
// accumulation field. The same float operations in the same order as the CPU.

layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;

layout(binding = LPV_TEX_FROM) uniform sampler3D from_field[3];
layout(binding = LPV_TEX_SCALE) uniform sampler3D scale_field[3];
layout(binding = LPV_TEX_CELLS) uniform usampler3D cells;
layout(binding = LPV_IMAGE_TO, rgba32f) uniform writeonly image3D to_field[3];
layout(binding = LPV_IMAGE_ACCUMULATED, rgba32f) uniform image3D accumulated[3];

uniform ivec3 size;
uniform int accumulate;  // 1: add this step to the accumulation field
// The matrices' entries (subsurface/lpv_sh.h, lpvPropagationMatrices): m00, m0a, ma0, maa, mbb.
uniform float m00, m0a, ma0, maa, mbb;

vec4 sent(int ch, ivec3 c) {
  return texelFetch(from_field[ch], c, 0) * texelFetch(scale_field[ch], c, 0);
}

void main() {
  ivec3 d = ivec3(gl_GlobalInvocationID);
  if (any(greaterThanEqual(d, size))) return;
  // Object cells are never on the grid's outer layer (lpvVoxelise, lpvTransfer).
  bool object = all(greaterThan(d, ivec3(0))) && all(lessThan(d, size - 1)) &&
                texelFetch(cells, d, 0).r != 0u;
  for (int ch = 0; ch < 3; ++ch) {
    vec4 result = vec4(0.0);
    if (object) {
      // x: the coupled coefficient is y11 (w); y: y1-1 (y); z: y10 (z). The lower neighbour's
      // light travels +axis, the upper's -axis.
      vec4 xl = sent(ch, d - ivec3(1, 0, 0)), xu = sent(ch, d + ivec3(1, 0, 0));
      vec4 yl = sent(ch, d - ivec3(0, 1, 0)), yu = sent(ch, d + ivec3(0, 1, 0));
      vec4 zl = sent(ch, d - ivec3(0, 0, 1)), zu = sent(ch, d + ivec3(0, 0, 1));
      vec4 xs = xl + xu, ys = yl + yu, zs = zl + zu;
      vec4 xd = xl - xu, yd = yl - yu, zd = zl - zu;
      result.x = m00 * (xs.x + ys.x + zs.x) + m0a * (xd.w + yd.y + zd.z);
      result.y = ma0 * yd.x + maa * ys.y + mbb * (xs.y + zs.y);
      result.z = ma0 * zd.x + maa * zs.z + mbb * (xs.z + ys.z);
      result.w = ma0 * xd.x + maa * xs.w + mbb * (ys.w + zs.w);
    }
    imageStore(to_field[ch], d, result);
    if (accumulate != 0 && object) {
      imageStore(accumulated[ch], d, imageLoad(accumulated[ch], d) + result);
    }
  }
}
