#version 450
#include "radiosity/progressive_bindings.glsl"
// The compute passes of GPU progressive radiosity (Wallner sec. 3 and 3.1), one program per
// PROGRESSIVE_PASS (src/penumbra/radiosity/progressive_gl.cpp):
//  0 power:    residual power of every shooter (a cluster of the hierarchy: a contiguous range
//              of elements), the sum over its occupied texels only of luminance(dB) (I = 0.3 R +
//              0.59 G + 0.11 B) times the element's area, and the RGB sum (W): the paper's
//              mipmap reduction over occupied texels, one invocation per shooter, in element
//              order and in double: the CPU's order and precision, so ties break alike.
//  1 select:   the shooter with the highest residual power, one work group, lowest index on
//              ties (the CPU's strict > scan). Only this winner is read back.
//  2 points:   the shooter's points (substructuring, sec. 3): per cluster of one level (a
//              contiguous range of elements) the sum of dB * area in double; read back, it gives
//              the power shot (the books), the points with something to shoot, and their
//              area-weighted mean dB; and the sum of luminance(dB) * area * position, which
//              places each point at its power's centroid (as on the CPU).
//  3 resolve:  after all shooter points: B += rho * scale * incident, dB += the same (eq. 1,
//              progressive form; scale = 1 unless the shot is closed), the shooter's dB = 0,
//              and per work group the sums of incident * area, (1 - rho) incident * area and
//              rho incident * area in double for the energy books (read back and summed on the
//              CPU); with apply = false only the sums.
//  4 radiance: the radiance atlas B / pi (+ rho * ambient / pi), alpha 1 on occupied texels.
//  5 fill:     one ping-pong pass of the sec. 3.1 post-process: an unoccupied texel next to
//              occupied texels of the same chart gets their mean (8-neighbourhood), alpha 1.
#include "radiosity/progressive_layout.glsl"

#if PROGRESSIVE_PASS == 0
layout(local_size_x = 64) in;
layout(std430, binding = PROGRESSIVE_SSBO_SHOOTERS) readonly buffer Shooters { GpuShooter shooters[]; };
layout(std430, binding = PROGRESSIVE_SSBO_ELEMENTS) readonly buffer Elements { GpuProgressiveElement elements[]; };
layout(std430, binding = PROGRESSIVE_SSBO_SHOOTER_POWER) writeonly buffer ShooterPower { dvec4 shooter_power[]; };
layout(std430, binding = PROGRESSIVE_SSBO_ELEMENT_AREA) readonly buffer ElementArea { double element_area[]; };
layout(binding = PROGRESSIVE_IMAGE_RESIDUAL, rgba32f) uniform readonly image2D residual;

uniform uint shooter_count;
uniform int atlas_width;

void main() {
  const uint t = gl_WorkGroupID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x +
                 gl_GlobalInvocationID.x;
  if (t >= shooter_count) return;
  const uint first = shooters[t].element_first, last = first + shooters[t].element_count;
  dvec3 rgb = dvec3(0.0);
  double lum = 0.0LF;
  for (uint e = first; e < last; ++e) {
    const uint texel = elements[e].texel;
    const dvec3 db = dvec3(imageLoad(residual, ivec2(int(texel % uint(atlas_width)),
                                                      int(texel / uint(atlas_width)))).rgb);
    const double a = element_area[e];
    lum += (0.3LF * db.x + 0.59LF * db.y + 0.11LF * db.z) * a;
    rgb += db * a;
  }
  shooter_power[t] = dvec4(rgb, lum);
}

#elif PROGRESSIVE_PASS == 1
layout(local_size_x = 256) in;
layout(std430, binding = PROGRESSIVE_SSBO_SHOOTER_POWER) readonly buffer ShooterPower { dvec4 shooter_power[]; };
layout(std430, binding = PROGRESSIVE_SSBO_SELECTION) writeonly buffer Selection { GpuSelection selection; };

uniform uint shooter_count;

shared double best_power[256];
shared uint best_triangle[256];

void main() {
  const uint lane = gl_LocalInvocationID.x;
  double power = 0.0LF;
  uint best = 0xffffffffu;
  for (uint t = lane; t < shooter_count; t += 256u) {
    const double p = shooter_power[t].w;
    if (p > power) {  // ascending t: the lowest index wins ties
      power = p;
      best = t;
    }
  }
  best_power[lane] = power;
  best_triangle[lane] = best;
  memoryBarrierShared();
  barrier();
  for (uint h = 128u; h > 0u; h >>= 1u) {
    if (lane < h) {
      const double p = best_power[lane + h];
      const uint t = best_triangle[lane + h];
      if (p > best_power[lane] || (p == best_power[lane] && t < best_triangle[lane])) {
        best_power[lane] = p;
        best_triangle[lane] = t;
      }
    }
    memoryBarrierShared();
    barrier();
  }
  if (lane == 0u) selection = GpuSelection(best_power[0], best_triangle[0], 0u);
}

#elif PROGRESSIVE_PASS == 2
layout(local_size_x = 64) in;
layout(std430, binding = PROGRESSIVE_SSBO_ELEMENTS) readonly buffer Elements { GpuProgressiveElement elements[]; };
layout(std430, binding = PROGRESSIVE_SSBO_POINTS) readonly buffer Points { GpuShooterPoint points[]; };
layout(std430, binding = PROGRESSIVE_SSBO_POINT_POWER) writeonly buffer PointPower { dvec4 point_power[]; };
layout(std430, binding = PROGRESSIVE_SSBO_ELEMENT_AREA) readonly buffer ElementArea { double element_area[]; };
layout(binding = PROGRESSIVE_IMAGE_RESIDUAL, rgba32f) uniform readonly image2D residual;

uniform uint point_first;
uniform uint point_count;
uniform int atlas_width;

void main() {
  const uint k = gl_GlobalInvocationID.x;
  if (k >= point_count) return;
  const uint p = point_first + k;
  const GpuShooterPoint s = points[p];
  dvec3 sum = dvec3(0.0);
  dvec4 moment = dvec4(0.0);  // sum of luminance(dB) area position, sum of luminance(dB) area
  for (uint q = 0u; q < s.member_count; ++q) {
    const uint e = s.member_first + q;
    const uint texel = elements[e].texel;
    const dvec3 db = dvec3(imageLoad(residual, ivec2(int(texel % uint(atlas_width)),
                                                      int(texel / uint(atlas_width)))).rgb);
    sum += db * element_area[e];
    const double w = (0.3LF * db.r + 0.59LF * db.g + 0.11LF * db.b) * element_area[e];
    moment += dvec4(dvec3(elements[e].position) * w, w);
  }
  point_power[2u * p] = dvec4(sum, 0.0LF);
  point_power[2u * p + 1u] = moment;
}

#elif PROGRESSIVE_PASS == 3
layout(local_size_x = 256) in;
layout(std430, binding = PROGRESSIVE_SSBO_ELEMENTS) readonly buffer Elements { GpuProgressiveElement elements[]; };
layout(std430, binding = PROGRESSIVE_SSBO_SUMS) writeonly buffer Sums { GpuResolveSums sums[]; };
layout(std430, binding = PROGRESSIVE_SSBO_ELEMENT_AREA) readonly buffer ElementArea { double element_area[]; };
// Its covered share (cut-outs): it intercepts that share of what arrives, the rest goes on to
// what lies behind it (ProgressiveRadiosity::applyIncident).
layout(std430, binding = PROGRESSIVE_SSBO_ELEMENT_COVERAGE) readonly buffer ElementCoverage { double element_coverage[]; };
layout(binding = PROGRESSIVE_IMAGE_RESIDUAL, rgba32f) uniform image2D residual;
layout(binding = PROGRESSIVE_IMAGE_RADIOSITY, rgba32f) uniform image2D radiosity;
layout(binding = PROGRESSIVE_TEXTURE_INCIDENT_MAP) uniform sampler2D incident_map;

uniform uint element_count;
uniform uvec2 shooter_elements;  // the shooter's elements: first, count
uniform int atlas_width;
uniform vec3 scale;  // closed shots: power shot / power arrived, per channel
uniform bool apply;  // false: only the sums

shared dvec3 arrived[256];
shared dvec3 absorbed[256];
shared dvec3 reflected[256];

void main() {
  const uint lane = gl_LocalInvocationID.x;
  const uint group = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
  const uint e = group * 256u + lane;
  dvec3 in_a = dvec3(0.0), ab_a = dvec3(0.0), re_a = dvec3(0.0);
  if (e < element_count) {
    const GpuProgressiveElement el = elements[e];
    const ivec2 xy = ivec2(int(el.texel % uint(atlas_width)), int(el.texel / uint(atlas_width)));
    const dvec3 inc = dvec3(texelFetch(incident_map, xy, 0).rgb) * dvec3(scale);
    const bool own = e - shooter_elements.x < shooter_elements.y;  // the shooter's element
    if (inc != dvec3(0.0)) {
      const dvec3 rho = dvec3(el.reflectance);
      const dvec3 gain = rho * inc;
      const double a = element_area[e];
      if (apply) {
        const vec4 b = imageLoad(radiosity, xy), db = imageLoad(residual, xy);
        imageStore(radiosity, xy, vec4(vec3(dvec3(b.rgb) + gain), b.a));
        // The shooter's own dB is zeroed before it gains (a curved chart lights itself).
        imageStore(residual, xy, vec4(vec3((own ? dvec3(0.0) : dvec3(db.rgb)) + gain), db.a));
      }
      const double c = element_coverage[e];
      in_a = inc * a * c;
      ab_a = (dvec3(c) - rho) * inc * a;
      re_a = gain * a;
    } else if (apply && own) {
      imageStore(residual, xy, vec4(0.0, 0.0, 0.0, 1.0));
    }
  }
  arrived[lane] = in_a;
  absorbed[lane] = ab_a;
  reflected[lane] = re_a;
  memoryBarrierShared();
  barrier();
  for (uint h = 128u; h > 0u; h >>= 1u) {
    if (lane < h) {
      arrived[lane] += arrived[lane + h];
      absorbed[lane] += absorbed[lane + h];
      reflected[lane] += reflected[lane + h];
    }
    memoryBarrierShared();
    barrier();
  }
  if (lane == 0u) {
    sums[group] = GpuResolveSums(dvec4(arrived[0], 0.0LF), dvec4(absorbed[0], 0.0LF),
                                 dvec4(reflected[0], 0.0LF));
  }
}

#elif PROGRESSIVE_PASS == 4
layout(local_size_x = 16, local_size_y = 16) in;
layout(std430, binding = PROGRESSIVE_SSBO_ELEMENTS) readonly buffer Elements { GpuProgressiveElement elements[]; };
layout(std430, binding = PROGRESSIVE_SSBO_TEXEL_ELEMENT) readonly buffer TexelElement { int texel_element[]; };
layout(binding = PROGRESSIVE_IMAGE_RADIOSITY, rgba32f) uniform readonly image2D radiosity;
layout(binding = PROGRESSIVE_IMAGE_RADIANCE, rgba32f) uniform writeonly image2D radiance;

uniform ivec2 atlas_size;
uniform vec3 ambient;  // eq. 4-6, zero unless asked for

const float kInvPi = 0.318309886183791;

void main() {
  const ivec2 xy = ivec2(gl_GlobalInvocationID.xy);
  if (xy.x >= atlas_size.x || xy.y >= atlas_size.y) return;
  const int e = texel_element[xy.y * atlas_size.x + xy.x];
  vec4 out_value = vec4(0.0);
  if (e >= 0) {
    out_value =
        vec4((imageLoad(radiosity, xy).rgb + elements[e].reflectance * ambient) * kInvPi, 1.0);
  }
  imageStore(radiance, xy, out_value);
}

#elif PROGRESSIVE_PASS == 5
layout(local_size_x = 16, local_size_y = 16) in;
layout(std430, binding = PROGRESSIVE_SSBO_TEXEL_CHART) readonly buffer TexelChart { int texel_chart[]; };
layout(binding = PROGRESSIVE_TEXTURE_SOURCE) uniform sampler2D source;
layout(binding = PROGRESSIVE_IMAGE_TARGET, rgba32f) uniform writeonly image2D target;

uniform ivec2 atlas_size;

void main() {
  const ivec2 xy = ivec2(gl_GlobalInvocationID.xy);
  if (xy.x >= atlas_size.x || xy.y >= atlas_size.y) return;
  vec4 v = texelFetch(source, xy, 0);
  const int t = texel_chart[xy.y * atlas_size.x + xy.x];
  if (v.a == 0.0 && t >= 0) {
    vec3 sum = vec3(0.0);
    int k = 0;
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const ivec2 q = xy + ivec2(dx, dy);
        if (q.x < 0 || q.y < 0 || q.x >= atlas_size.x || q.y >= atlas_size.y) continue;
        const vec4 n = texelFetch(source, q, 0);
        if (n.a == 0.0 || texel_chart[q.y * atlas_size.x + q.x] != t) continue;
        sum += n.rgb;
        ++k;
      }
    }
    if (k > 0) v = vec4(sum / float(k), 1.0);
  }
  imageStore(target, xy, v);
}
#endif
