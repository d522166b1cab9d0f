#version 450
#include "radiosity/jacobi_bindings.glsl"
// One Jacobi iteration of matrix radiosity (Carr, Hall, Hart 2003, sec. 3), eq. 4:
//   B' = B + diag(M)^-1 (E - M B),  M = I - diag(rho) F,  so  (M B)_i = B_i - rho_i (F B)_i,
// per RGB channel, F shared by the channels. The paper splits each matrix-vector product into
// passes over blocks of columns (254 per pass on its GeForce FX); so does the product pass
// here, with one work group per (column block, row tile). Three programs come from this file,
// chosen by JACOBI_PASS; every sum is in a fixed order (no atomics): results are deterministic.
//
// Defines from src/penumbra/radiosity/jacobi_gl.cpp: JACOBI_PASS (0 product, 1 update,
// 2 reduce), JACOBI_FP16 (1: F as packed binary16), and the constants of jacobi_layout.glsl.
#include "radiosity/jacobi_layout.glsl"

#if JACOBI_PASS == 0
// ---- Pass 1: partials[block][i] = sum_{j in block} F_ij B_j, RGB at once ----
layout(local_size_x = LANES, local_size_y = WARPS) in;

#if JACOBI_FP16
// Row i, columns 2k and 2k + 1 in word i * row_words + k (low half first).
layout(std430, binding = JACOBI_SSBO_MATRIX) readonly buffer Matrix { uint f[]; };
#else
layout(std430, binding = JACOBI_SSBO_MATRIX) readonly buffer Matrix { float f[]; };
#endif
layout(std430, binding = JACOBI_SSBO_RADIOSITY) readonly buffer Radiosity { GpuRgb b[]; };
layout(std430, binding = JACOBI_SSBO_PARTIALS) writeonly buffer Partials { GpuRgb partials[]; };

uniform uint n;          // elements
uniform uint row_words;  // matrix words per row: n (fp32), ceil(n / 2) (fp16)

const uint kGroupRows = WARPS * ROWS_PER_WARP;

// The block's segment of B, one array per channel (no bank conflicts from vec3 strides).
shared float segment[3][BLOCK_COLUMNS];
// Each lane's partial sums, reduced across the lanes of a row in a fixed tree.
shared float lanes[3][kGroupRows][LANES];

vec3 segmentAt(uint k) { return vec3(segment[0][k], segment[1][k], segment[2][k]); }

void main() {
  const uint block = gl_WorkGroupID.x;
  const uint col0 = block * BLOCK_COLUMNS;
  const uint lane = gl_LocalInvocationID.x, warp = gl_LocalInvocationID.y;
  const uint local_index = warp * LANES + lane;
  for (uint k = local_index; k < BLOCK_COLUMNS; k += LANES * WARPS) {
    const uint j = col0 + k;
    const vec3 v = j < n ? b[j].rgb : vec3(0.0);  // columns past N contribute nothing
    segment[0][k] = v.x;
    segment[1][k] = v.y;
    segment[2][k] = v.z;
  }
  memoryBarrierShared();
  barrier();

  const uint tile_row = warp * ROWS_PER_WARP;
  const uint row0 = gl_WorkGroupID.y * kGroupRows + tile_row;
  for (uint q = 0u; q < ROWS_PER_WARP; ++q) {
    const uint row = row0 + q;
    vec3 acc = vec3(0.0);
    if (row < n) {
#if JACOBI_FP16
      // Lane k reads words k, k + 32, ...: 32 consecutive words (64 form factors) per read.
      const uint w0 = col0 / 2u, row_base = row * row_words;
      for (uint k = lane; k < BLOCK_COLUMNS / 2u; k += LANES) {
        if (w0 + k < row_words) {
          const vec2 fij = unpackHalf2x16(f[row_base + w0 + k]);  // the CPU's binary16 bits
          acc += fij.x * segmentAt(2u * k) + fij.y * segmentAt(2u * k + 1u);
        }
      }
#else
      const uint row_base = row * n;
      for (uint k = lane; k < BLOCK_COLUMNS; k += LANES) {
        if (col0 + k < n) acc += f[row_base + col0 + k] * segmentAt(k);
      }
#endif
    }
    lanes[0][tile_row + q][lane] = acc.x;
    lanes[1][tile_row + q][lane] = acc.y;
    lanes[2][tile_row + q][lane] = acc.z;
  }
  memoryBarrierShared();
  barrier();
  for (uint s = LANES / 2u; s > 0u; s >>= 1u) {
    if (lane < s) {
      for (uint q = 0u; q < ROWS_PER_WARP; ++q) {
        const uint r = tile_row + q;
        for (uint c = 0u; c < 3u; ++c) lanes[c][r][lane] += lanes[c][r][lane + s];
      }
    }
    memoryBarrierShared();
    barrier();
  }
  if (lane == 0u) {
    for (uint q = 0u; q < ROWS_PER_WARP; ++q) {
      const uint row = row0 + q;
      if (row < n) {
        const uint r = tile_row + q;
        const vec3 sum = vec3(lanes[0][r][0], lanes[1][r][0], lanes[2][r][0]);
        partials[block * n + row] = GpuRgb(sum, 0.0);
      }
    }
  }
}

#elif JACOBI_PASS == 1
// ---- Pass 2: (F B)_i from the partials in block order, then eq. 4 and |(M B - E)_i|^2 ----
layout(local_size_x = UPDATE_GROUP) in;

layout(std430, binding = JACOBI_SSBO_RADIOSITY) readonly buffer Radiosity { GpuRgb b[]; };
layout(std430, binding = JACOBI_SSBO_PARTIALS) readonly buffer Partials { GpuRgb partials[]; };
layout(std430, binding = JACOBI_SSBO_ELEMENTS) readonly buffer Elements { GpuJacobiElement elements[]; };
layout(std430, binding = JACOBI_SSBO_NEXT) writeonly buffer Next { GpuRgb next[]; };
layout(std430, binding = JACOBI_SSBO_ROW_RESIDUAL) writeonly buffer RowResidual { double row_residual[]; };

uniform uint n;
uniform uint blocks;

void main() {
  const uint i = gl_GlobalInvocationID.x;
  if (i >= n) return;
  // N values per iteration: double costs nothing here and matches the CPU twin's update.
  dvec3 g = dvec3(0.0);
  for (uint k = 0u; k < blocks; ++k) g += dvec3(partials[k * n + i].rgb);
  const GpuJacobiElement e = elements[i];
  const dvec3 bi = dvec3(b[i].rgb), rho = dvec3(e.reflectance);
  // (M B - E)_i = B_i - rho_i (F B)_i - E_i (eq. 2); diag(M)_ii = 1 - rho_i F_ii (eq. 4).
  const dvec3 r = bi - rho * g - dvec3(e.emission);
  const dvec3 updated = bi - r / (1.0LF - rho * double(e.self_form_factor));
  next[i] = GpuRgb(vec3(updated), 0.0);
  row_residual[i] = r.x * r.x + r.y * r.y + r.z * r.z;
}

#elif JACOBI_PASS == 2
// ---- Pass 3: sum of the rows' squared residuals, one group, fixed order ----
layout(local_size_x = REDUCE_GROUP) in;

layout(std430, binding = JACOBI_SSBO_ROW_RESIDUAL) readonly buffer RowResidual { double row_residual[]; };
layout(std430, binding = JACOBI_SSBO_RESULT) buffer Result { double result[]; };

uniform uint n;
uniform uint slot;

shared double sums[REDUCE_GROUP];

void main() {
  const uint t = gl_LocalInvocationID.x;
  double s = 0.0LF;
  for (uint i = t; i < n; i += REDUCE_GROUP) s += row_residual[i];
  sums[t] = s;
  memoryBarrierShared();
  barrier();
  for (uint h = REDUCE_GROUP / 2u; h > 0u; h >>= 1u) {
    if (t < h) sums[t] += sums[t + h];
    memoryBarrierShared();
    barrier();
  }
  if (t == 0u) result[slot] = sums[0];
}
#endif
