#version 450
// The receiver pass's fragment stage (Wallner sec. 3): one fragment per receiver texel, which
// gathers from a batch of shooter points (one draw per batch rather than per point: draw calls
// are what a software rasteriser pays most for). The texel's element (the CPU solver's element:
// its exact-coverage centroid, area and reflectance, looked up by texel, not interpolated, so
// that the polygon's and the outline's fragments of a texel compute the same value) is
// back-projected into each point's depth map (progressive_hemisphere.glsl), compared with the
// depth there and at the 8 neighbouring texels of the map (Fig. 3), and, if visible, gathers the
// irradiance dB_s F_rs (W m^-2) with eq. 2's disc form factor, or for pairs closer than kNear
// shooter element sizes with Lambert's exact form factor to each of the shooter point's element
// polygons (as the CPU solver does). The sum is added into the incident target by blending.
//
// Exactly once per texel and batch: a fragment writes only into a kInside texel of its own
// triangle (discard otherwise), and the stencil test (GL_NOTEQUAL stamp, then GL_REPLACE) lets
// only the first fragment that reaches a texel in primitive order through, so the polygon, the
// outline and the corner points never add twice. Stencil test and blending are framebuffer
// operations, done in primitive order: no atomics, no ordering hazards.
//
// Two programs come from this file: NEAR_PASS 0 gathers the far pairs with eq. 2's disc over all
// receivers; NEAR_PASS 1 the near pairs (closer than kNear shooter element sizes) with the exact
// form factor, drawn only for the receiver triangles that can be that close to the shooter
// (progressive_gl.cpp), so that the heavy polygon code runs only where it is needed. VISIBILITY
// (ProgressiveOptions::visibility) compiles the depth test in or out.
#include "radiosity/progressive_layout.glsl"
#include "radiosity/progressive_hemisphere.glsl"
#include "radiosity/progressive_form_factor.glsl"

layout(std430, binding = 0) readonly buffer Triangles { GpuProgressiveTriangle triangles[]; };
layout(std430, binding = 2) readonly buffer Elements { GpuProgressiveElement elements[]; };
layout(std430, binding = 3) readonly buffer TexelElement { int texel_element[]; };
layout(std430, binding = 6) readonly buffer Members { uint members[]; };
// Element polygons that are not whole texel squares (along the chart's edges), 8 corners each
// (xyz, padded by repeating the last corner).
layout(std430, binding = 18) readonly buffer Polygons { vec4 polygons[]; };
// Element points in double, for the near-pair test in the CPU's precision.
layout(std430, binding = 15) readonly buffer ElementPositionD { double element_position[]; };
layout(std140, binding = 0) uniform Batch { GpuBatchPoint batch[MAX_BATCH_POINTS]; };

layout(binding = 0) uniform sampler2D depth_map;     // tiles of linear depth, Algorithm 1
layout(binding = 1) uniform sampler2D residual_map;  // dB atlas (RGBA32F, alpha = occupied)

uniform Hemisphere hemisphere;  // the shooter's frame; the origin is each point's position
uniform uint batch_count;       // points in the batch
uniform uint tiles;             // tiles x tiles depth maps in depth_map, tile k for point k
uniform uint shooter;           // the shooter triangle
uniform int atlas_width;
uniform float depth_tolerance;  // relative
uniform float near_factor;      // kNear: exact form factor when d^2 < kNear^2 A_s
uniform bool count_mode;        // diagnostics: add 1 per fragment that gets through

// The stencil guard runs before shading: a texel's second and third fragments (outline, corner
// point) are dropped unshaded. A fragment that then discards has still claimed its texel, which
// is harmless: its texel is not a kInside texel, or it would have added nothing (every fragment
// of a texel computes the same value), or it is another triangle's texel, which cannot happen
// (charts are at least two texels apart, and a line's fragments lie within half a texel of it).
layout(early_fragment_tests) in;

flat in uint v_triangle;
layout(location = 0) out vec4 incident;

// Fig. 3: visible when the depth map of batch point k holds, at the back-projected texel or
// one of its eight neighbours (within the tile), nothing nearer than the element (up to the
// tolerance).
bool visibleFromShooter(vec3 image, uint k) {
  const int size = textureSize(depth_map, 0).x / int(tiles);
  const ivec2 origin = ivec2(tileOrigin(k, tiles)) * size;
  const ivec2 px = ivec2(floor((image.xy * 0.5 + 0.5) * float(size)));
  float farthest = 0.0;
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      const ivec2 q = clamp(px + ivec2(dx, dy), ivec2(0), ivec2(size - 1));
      farthest = max(farthest, texelFetch(depth_map, origin + q, 0).r);
    }
  }
  return farthest >= image.z * (1.0 - depth_tolerance) - 1e-7;
}

// Whether receiver r (its point in double: pr) and batch point k make a pair of this pass:
// in front of each other's planes (one-sided elements), apart, and near (NEAR_PASS 1) or far
// (NEAR_PASS 0). Near or far is decided in the CPU's precision: exact ties at
// d^2 = kNear^2 A are common on regular meshes.
bool isPair(dvec3 pr, GpuProgressiveElement r, vec3 nr, uint k) {
  const vec3 d = batch[k].position_f.xyz - r.position;
  const dvec3 dd = batch[k].position.xyz - pr;
  const double dd2 = dd.x * dd.x + dd.y * dd.y + dd.z * dd.z;
  const bool near = dd2 < double(near_factor) * double(near_factor) * batch[k].position.w;
  return dot(d, d) > 0.0 && dot(nr, d) > 0.0 && dot(hemisphere.normal, d) < 0.0 &&
         near == (NEAR_PASS == 1);
}

// Visibility of receiver r from batch point k: the back projection of its point into the
// point's depth map and the Fig. 3 test (compiled out when visibility is off).
bool seenFrom(GpuProgressiveElement r, GpuProgressiveTriangle rt, uint k) {
#if VISIBILITY
  Hemisphere h = hemisphere;
  h.origin = batch[k].position_f.xyz;
  vec3 image;
  return backProject(h, rt, r.barycentric, image) && visibleFromShooter(image, k);
#else
  return true;
#endif
}

#if NEAR_PASS
// Near pairs (across an edge, in a corner): Lambert's exact form factor to each of batch point
// k's element polygons, times their dB, as the CPU does (W m^-2).
vec3 gatherNear(GpuProgressiveElement r, vec3 nr, uint k) {
  const GpuProgressiveTriangle st = triangles[shooter];
  // Half the lattice steps along the chart's legs, in world space: a whole texel's square.
  vec3 p[3] = vec3[3](st.p0, st.p1, st.p2);
  const float half_step = 0.5 / float(st.leg);
  const vec3 hu = (p[(st.right + 1u) % 3u] - p[st.right]) * half_step;
  const vec3 hv = (p[(st.right + 2u) % 3u] - p[st.right]) * half_step;
  vec3 sum = vec3(0.0);
  for (uint q = 0u; q < batch[k].members.y; ++q) {
    const GpuProgressiveElement m = elements[members[batch[k].members.x + q]];
    vec3 poly[8];
    if (m.polygon == 0xffffffffu) {
      poly[0] = m.position - hu - hv;
      poly[1] = m.position + hu - hv;
      poly[2] = m.position + hu + hv;
      poly[3] = m.position - hu + hv;
      for (int c = 4; c < 8; ++c) poly[c] = poly[3];
    } else {
      for (int c = 0; c < 8; ++c) poly[c] = polygons[8u * m.polygon + uint(c)].xyz;
    }
    const ivec2 mt = ivec2(int(m.texel % uint(atlas_width)), int(m.texel / uint(atlas_width)));
    const vec3 db = texelFetch(residual_map, mt, 0).rgb;
    sum += db * pointToPolygonFormFactor(r.position, nr, poly);
  }
  return sum;
}
#else
// Far pairs: eq. 2's disc (m = 1) times the point's mean dB (W m^-2).
vec3 gatherFar(GpuProgressiveElement r, vec3 nr, uint k) {
  const vec3 d = batch[k].position_f.xyz - r.position;
  const float d2 = dot(d, d);
  const float inv = inversesqrt(d2);
  const float cos_r = dot(nr, d) * inv, cos_s = -dot(hemisphere.normal, d) * inv;
  return batch[k].residual.rgb * discFormFactor(batch[k].position_f.w, cos_s, cos_r, d2);
}
#endif

void main() {
  const ivec2 texel = ivec2(gl_FragCoord.xy);
  const int e = texel_element[texel.y * atlas_width + texel.x];
  if (e < 0) discard;  // not a kInside texel
  const GpuProgressiveElement r = elements[e];
  if (r.triangle != v_triangle) discard;  // another triangle's texel (line fragments)
  if (count_mode) {
    incident = vec4(1.0, 0.0, 0.0, 0.0);
    return;
  }
  const GpuProgressiveTriangle rt = triangles[r.triangle];
  const dvec3 pr = dvec3(element_position[3 * e], element_position[3 * e + 1],
                         element_position[3 * e + 2]);
  // This pass's pairs of the batch as a bit mask, then a loop over its set bits. A SIMD
  // rasteriser (llvmpipe) runs both sides of every branch under lane masks, but leaves a loop
  // as soon as no lane has work: the expensive part costs only what the pairs need.
  uint pairs = 0u;
  for (uint k = 0u; k < batch_count; ++k) {
    if (isPair(pr, r, rt.normal, k)) pairs |= 1u << k;
  }
  vec3 sum = vec3(0.0);
  while (pairs != 0u) {
    const uint k = uint(findLSB(pairs));
    pairs &= pairs - 1u;
    if (!seenFrom(r, rt, k)) continue;
#if NEAR_PASS
    sum += gatherNear(r, rt.normal, k);
#else
    sum += gatherFar(r, rt.normal, k);
#endif
  }
  if (sum == vec3(0.0)) discard;  // nothing to add (the texel's other fragments agree)
  incident = vec4(sum, 0.0);
}
