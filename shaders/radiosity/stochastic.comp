#version 450
#include "radiosity/stochastic_bindings.glsl"
// Stochastic radiosity on the GPU (Barsi and Jakab). Shooter selection (sec. 3.1): the mipmap
// of lum(B) A built and descended on the device, so that only the chosen texel (32 bytes) is read
// back, never the radiosity (the paper names that readback as its bottleneck). The twin of
// StochasticRadiosity::buildSums and ::select (src/penumbra/radiosity/stochastic.cpp): the same
// hierarchy, the same order of summation in double, the same descent, so that the same u picks
// the same texel on both devices. One program per STOCHASTIC_PASS:
//  0 texels:  sums[e] = max(lum(B_e), 0) A_e, lum = 0.3 R + 0.59 G + 0.11 B;
//  1 level:   each cluster of one level: the sum of its children's, in order;
//  2 descent: one invocation: the chart root whose running sum passes u Phi, then at each level
//             the child whose running sum passes the remaining value, down to a texel; writes
//             the texel, its probability, Phi and the texel's radiosity.
// The shot itself is the hemispherical gather's (radiosity/hemisphere_gl.h); then
//  5 local:   the local operator's irradiance per element, sum f_rj B_j over its pairs (CSR,
//             StochasticRadiosity::local), from B_{m-1}, before the update overwrites it;
//  3 update:  eq. 3's new iterate B_m = E' + rho (E_local + E_in) per element (E_in the
//             gathered irradiance), in double, and eq. 2's running sums (by the iterate's parity);
//  4 error:   the error estimate's sums, per work group: area-weighted squares of half the
//             difference of the odd and even means and of the estimate (the first shots' B_p -
//             dB plus the mean; luminance).

#include "radiosity/progressive_layout.glsl"
#include "radiosity/stochastic_layout.glsl"

double luminance(dvec3 b) { return 0.3LF * b.x + 0.59LF * b.y + 0.11LF * b.z; }

#if STOCHASTIC_PASS == 0
layout(local_size_x = 256) in;
layout(std430, binding = STOCHASTIC_SSBO_ITERATE) readonly buffer Iterate { dvec4 iterate[]; };
layout(std430, binding = STOCHASTIC_SSBO_AREA) readonly buffer Area { double area[]; };
layout(std430, binding = STOCHASTIC_SSBO_SUMS) writeonly buffer Sums { double sums[]; };
uniform uint count;

void main() {
  const uint e = gl_WorkGroupID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x +
                 gl_GlobalInvocationID.x;
  if (e >= count) return;
  sums[e] = max(luminance(iterate[e].xyz), 0.0LF) * area[e];
}

#elif STOCHASTIC_PASS == 1
layout(local_size_x = 256) in;
layout(std430, binding = STOCHASTIC_SSBO_SUMS) buffer Sums { double sums[]; };
layout(std430, binding = STOCHASTIC_SSBO_CHILD_FIRST) readonly buffer ChildFirst { uint child_first[]; };
uniform uint count;         // clusters of this level
uniform uint offset;        // this level's first sum
uniform uint below_offset;  // the level below's first sum
uniform uint first_offset;  // this level's child_first entries (count + 1 of them)

void main() {
  const uint k = gl_WorkGroupID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x +
                 gl_GlobalInvocationID.x;
  if (k >= count) return;
  double s = 0.0LF;
  for (uint c = child_first[first_offset + k]; c < child_first[first_offset + k + 1u]; ++c) {
    s += sums[below_offset + c];
  }
  sums[offset + k] = s;
}

#elif STOCHASTIC_PASS == 2
layout(local_size_x = 1) in;
layout(std430, binding = STOCHASTIC_SSBO_SUMS) readonly buffer Sums { double sums[]; };
layout(std430, binding = STOCHASTIC_SSBO_CHILD_FIRST) readonly buffer ChildFirst { uint child_first[]; };
// Per chart: its root's level and index.
layout(std430, binding = STOCHASTIC_SSBO_ROOTS) readonly buffer Roots { uvec2 roots[]; };
layout(std430, binding = STOCHASTIC_SSBO_ITERATE) readonly buffer Iterate { dvec4 iterate[]; };
layout(std430, binding = STOCHASTIC_SSBO_SELECTION) writeonly buffer Selection { GpuStochasticSelection selection; };
uniform uint chart_count;
uniform double u;
// Per level l: its first sum and its first child_first entry.
uniform uint level_offset[32];
uniform uint first_offset[32];

double rootWeight(uint c) { return sums[level_offset[roots[c].x] + roots[c].y]; }

void main() {
  double total = 0.0LF;
  for (uint c = 0u; c < chart_count; ++c) total += rootWeight(c);
  if (!(total > 0.0LF)) {
    selection.found = 0u;
    return;
  }
  double x = clamp(u, 0.0LF, 1.0LF) * total;
  // upper_bound over the running sums: the first chart whose running sum exceeds x.
  double running = 0.0LF, before = 0.0LF;
  uint c = chart_count;
  for (uint k = 0u; k < chart_count; ++k) {
    const double next = running + rootWeight(k);
    if (next > x) {
      c = k;
      before = running;
      break;
    }
    running = next;
  }
  if (c >= chart_count) {
    // u = 1 or rounding at the top end: the last chart with weight.
    c = chart_count - 1u;
    while (c > 0u && rootWeight(c) <= 0.0LF) --c;
    double cdf = 0.0LF;
    for (uint k = 0u; k <= c; ++k) cdf += rootWeight(k);
    x = min(x, cdf * (1.0LF - 1e-16LF));
    // The running sum up to c - 1 (the same additions in the same order as the CPU's).
    before = 0.0LF;
    for (uint k = 0u; k < c; ++k) before += rootWeight(k);
  }
  x -= before;
  uint level = roots[c].x, index = roots[c].y;
  while (level > 0u) {
    const uint first = child_first[first_offset[level] + index];
    const uint last = child_first[first_offset[level] + index + 1u];
    const uint below = level_offset[level - 1u];
    uint pick = last - 1u;
    while (pick > first && sums[below + pick] <= 0.0LF) --pick;
    for (uint ch = first; ch < last; ++ch) {
      const double w = sums[below + ch];
      if (w <= 0.0LF) continue;
      if (x < w) {
        pick = ch;
        break;
      }
      x -= w;
    }
    level -= 1u;
    index = pick;
  }
  selection.element = index;
  selection.found = 1u;
  selection.probability = sums[index] / total;
  selection.power = total;
  selection.value = iterate[index];
}

#elif STOCHASTIC_PASS == 3
layout(local_size_x = 256) in;
layout(std430, binding = STOCHASTIC_SSBO_ELEMENTS) readonly buffer Elements { GpuProgressiveElement elements[]; };
layout(std430, binding = STOCHASTIC_SSBO_SOURCE) readonly buffer Source { dvec4 source[]; };
layout(std430, binding = STOCHASTIC_SSBO_ITERATE) writeonly buffer Iterate { dvec4 iterate[]; };
// Sums of the averaged iterates: [0, count) even, [count, 2 count) odd.
layout(std430, binding = STOCHASTIC_SSBO_AVERAGE) buffer Average { dvec4 sums[]; };
layout(binding = STOCHASTIC_TEXTURE_INCIDENT) uniform sampler2D incident;
layout(std430, binding = STOCHASTIC_SSBO_LOCAL_IN) readonly buffer LocalIn { dvec4 local_in[]; };
uniform uint count;
uniform int atlas_width;
uniform int sum_index;  // the parity of the iterate's number among the averaged; -1: burn-in

void main() {
  const uint e = gl_WorkGroupID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x +
                 gl_GlobalInvocationID.x;
  if (e >= count) return;
  const GpuProgressiveElement el = elements[e];
  const ivec2 t = ivec2(int(el.texel % uint(atlas_width)), int(el.texel / uint(atlas_width)));
  // Eq. 3: B_m = E' + L B_{m-1} + R* B_{m-1} = E' + rho (E_local + E_in).
  const dvec3 next =
      source[e].xyz +
      dvec3(el.reflectance) * (local_in[e].xyz + dvec3(texelFetch(incident, t, 0).rgb));
  iterate[e] = dvec4(next, 0.0LF);
  if (sum_index >= 0) sums[uint(sum_index) * count + e] += dvec4(next, 0.0LF);
}

#elif STOCHASTIC_PASS == 4
layout(local_size_x = 256) in;
layout(std430, binding = STOCHASTIC_SSBO_AREA) readonly buffer Area { double area[]; };
layout(std430, binding = STOCHASTIC_SSBO_AVERAGE) readonly buffer Average { dvec4 sums[]; };
layout(std430, binding = STOCHASTIC_SSBO_PARTIAL) writeonly buffer Partial { dvec2 partial[]; };
// w: the luminance of the first shots' B_p - dB, part of the estimate's mean.
layout(std430, binding = STOCHASTIC_SSBO_SOURCE) readonly buffer Source { dvec4 source[]; };
uniform uint count;
uniform double odd;   // averaged iterates with odd numbers
uniform double even;  // and with even ones
shared dvec2 part[256];

void main() {
  const uint e = gl_WorkGroupID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x +
                 gl_GlobalInvocationID.x;
  dvec2 v = dvec2(0.0LF);
  if (e < count) {
    const dvec3 se = sums[e].xyz, so = sums[count + e].xyz;
    const double d = 0.5LF * luminance(so / odd - se / even);
    const double m = source[e].w + luminance((so + se) / (odd + even));
    v = area[e] * dvec2(d * d, m * m);
  }
  const uint l = gl_LocalInvocationIndex;
  part[l] = v;
  barrier();
  for (uint stride = 128u; stride > 0u; stride >>= 1) {
    if (l < stride) part[l] += part[l + stride];
    barrier();
  }
  if (l == 0u) partial[gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x] = part[0];
}

#elif STOCHASTIC_PASS == 5
layout(local_size_x = 256) in;
layout(std430, binding = STOCHASTIC_SSBO_LOCAL_FIRST) readonly buffer LocalFirst { uint local_first[]; };
// (element, floatBitsToUint(factor)) per pair.
layout(std430, binding = STOCHASTIC_SSBO_LOCAL) readonly buffer Local { uvec2 local_pairs[]; };
layout(std430, binding = STOCHASTIC_SSBO_ITERATE) readonly buffer Iterate { dvec4 iterate[]; };
layout(std430, binding = STOCHASTIC_SSBO_LOCAL_IN) writeonly buffer LocalIn { dvec4 local_in[]; };
uniform uint count;

void main() {
  const uint e = gl_WorkGroupID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x +
                 gl_GlobalInvocationID.x;
  if (e >= count) return;
  // In the CPU's order and precision (StochasticRadiosity::step).
  dvec3 sum = dvec3(0.0LF);
  for (uint k = local_first[e]; k < local_first[e + 1u]; ++k) {
    const uvec2 p = local_pairs[k];
    sum += double(uintBitsToFloat(p.y)) * iterate[p.x].xyz;
  }
  local_in[e] = dvec4(sum, 0.0LF);
}
#endif
