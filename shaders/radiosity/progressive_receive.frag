#version 450
#include "radiosity/progressive_bindings.glsl"
// The receiver pass's fragment stage (Wallner sec. 3): one fragment per receiver element (a
// point at its texel, progressive_receive.vert), which gathers from a batch of shooter points
// (one draw per batch rather than per point: draw calls are what a software rasteriser pays
// most for). The element (the CPU solver's: its exact-coverage centroid, normal, area and
// reflectance) is back-projected into each point's depth map (progressive_hemisphere.glsl),
// compared with the depth there and at the 8 neighbouring texels of the map (Fig. 3), and, if
// visible, gathers the irradiance dB_s F_rs (W m^-2) as the CPU solver does: with eq. 2's disc
// form factor for pairs kFar point sizes apart or more, Lambert's exact form factor to the
// point's pieces (its faces clipped to its texels) with its mean dB nearer, and for pairs closer
// than kNear sizes Lambert's form factor to each of the point's elements' own pieces. The sum is
// added into the incident target by blending.
//
// Two programs come from this file: NEAR_PASS 0 gathers the far pairs (disc or point pieces)
// over all receivers; NEAR_PASS 1 the near pairs (closer than kNear shooter element sizes) with the exact
// form factor, drawn only for the charts that can be that close to the shooter
// (progressive_gl.cpp), so that the heavy polygon code runs only where it is needed. VISIBILITY
// (ProgressiveOptions::visibility) compiles the depth test in or out.
//
// Receivers are the elements, or clusters of them (Wallner sec. 4, radiosity/progressive_receivers.h)
// in the same layout, each drawn at one texel. SAMPLE_PASS 1 is sec. 4's test before a shooter's
// first shot, drawn over the elements: element e pairs with the shooter's point e mod
// sample_points (the CPU's pairing) and, if that point is in the batch, records in samples[e]
// bit 0 when the two face each other (the fragments the paper's first pass counts, n_r) and
// bit 1 when the depth test finds it visible too (its third pass, n_v).
#include "radiosity/progressive_layout.glsl"
#include "radiosity/progressive_hemisphere.glsl"
#include "radiosity/progressive_form_factor.glsl"
#include "common/watertight.glsl"
#include "common/cutout.glsl"

layout(std430, binding = PROGRESSIVE_SSBO_TRIANGLES) readonly buffer Triangles { GpuProgressiveTriangle triangles[]; };
layout(std430, binding = PROGRESSIVE_SSBO_ELEMENTS) readonly buffer Elements { GpuProgressiveElement elements[]; };
layout(std430, binding = PROGRESSIVE_SSBO_RECEIVERS) readonly buffer Receivers { GpuProgressiveElement receivers[]; };
#if SAMPLE_PASS
layout(std430, binding = PROGRESSIVE_SSBO_SAMPLES) buffer Samples { uint samples[]; };
uniform uint sample_points;  // the shooter's points
#endif
// Element pieces (its faces clipped to its texel, in world space), 8 corners each (xyz, padded
// by repeating the last corner).
layout(std430, binding = PROGRESSIVE_SSBO_POLYGONS) readonly buffer Polygons { vec4 polygons[]; };
// Shooter points' pieces (their faces clipped to their texels), 8 corners each, as above.
layout(std430, binding = PROGRESSIVE_SSBO_POINT_POLYGONS) readonly buffer PointPolygons { vec4 point_polygons[]; };
// Receiver points in double, for the near-pair test in the CPU's precision.
layout(std430, binding = PROGRESSIVE_SSBO_ELEMENT_POSITION_D) readonly buffer ReceiverPositionD { double receiver_position[]; };
#ifndef MAX_BATCH_POINTS
#error "MAX_BATCH_POINTS comes from the host (radiosity/hemisphere_gl.h: batchPointDefines)"
#endif
layout(std140, binding = PROGRESSIVE_UBO_BATCH) uniform Batch { GpuBatchPoint batch[MAX_BATCH_POINTS]; };

layout(binding = PROGRESSIVE_TEXTURE_DEPTH_MAP) uniform sampler2D depth_map;     // tiles of linear depth, Algorithm 1
layout(binding = PROGRESSIVE_TEXTURE_RESIDUAL_MAP) uniform sampler2D residual_map;  // dB atlas (RGBA32F, alpha = occupied)
layout(binding = PROGRESSIVE_TEXTURE_ID_MAP) uniform usampler2D id_map;       // the nearest triangle per depth texel
layout(std430, binding = PROGRESSIVE_SSBO_TEXEL_CHART) readonly buffer TexelChart { int texel_chart[]; };
// Charts that touch chart c: chart_adjacency[chart_adjacency_first[c] ..
// chart_adjacency_first[c + 1]).
layout(std430, binding = PROGRESSIVE_SSBO_ADJACENCY_FIRST) readonly buffer AdjacencyFirst { uint chart_adjacency_first[]; };
layout(std430, binding = PROGRESSIVE_SSBO_ADJACENCY) readonly buffer Adjacency { uint chart_adjacency[]; };

uniform Hemisphere hemisphere;  // the shooter's frame; the origin is each point's position
uniform uint batch_count;       // points in the batch
uniform uint tiles;             // tiles x tiles depth maps in depth_map, tile k for point k
uniform int atlas_width;
uniform float depth_tolerance;  // relative
uniform float near_factor;      // kNear: the members' form factors when d^2 < kNear^2 A_s
uniform float far_factor;       // kFar: the point's pieces' form factor when d^2 < kFar^2 A_s
uniform float local_factor;     // pairs with d^2 < local^2 A_s are left out (0: none)
uniform bool count_mode;        // diagnostics: add 1 per fragment that gets through

flat in uint v_element;
layout(location = 0) out vec4 incident;

// Whether chart `seen` is `chart` or touches it.
bool nextTo(int seen, int chart) {
  if (seen < 0) return false;
  if (seen == chart) return true;
  for (uint i = chart_adjacency_first[chart]; i < chart_adjacency_first[chart + 1]; ++i) {
    if (int(chart_adjacency[i]) == seen) return true;
  }
  return false;
}

// Fig. 3: visible when the depth map of batch point k holds, at the back-projected texel,
// nothing nearer than the element (up to the tolerance), or when that texel sees the element's
// own surface or a surface touching it (a triangle with a face in its chart or in a chart that
// shares a corner with it: its surface seen at a grazing angle, rasterised slightly nearer, or
// the neighbouring face across an edge). Asking that the centre see a connected surface keeps
// the test from letting light past an unconnected occluder's silhouette (the inner faces of a
// box lit from outside, the ceiling 0.8 mm above the Cornell box's light). The paper's
// neighbourhood asks besides that one of the eight neighbouring texels see nothing nearer; near
// the horizon of a point's map (a ceiling seen from the top of a wall) every one of them can
// hold the element's own surface a little nearer, and that test hid 10-16% of the light in the
// Cornell box's corners, so the texels' triangles are tested exactly instead:
// a triangle that one of the nine texels sees nearer than the element and that the
// segment from the element to the point crosses (the watertight ray-triangle test) occludes:
// next to an edge, neighbouring triangles' sub-triangle tessellations part by up to a texel, so
// the texel may show the element's own (two-sided) wall where the face over the edge blocks it,
// and light would reach the inside of a closed box past its edges. A cut-out that a texel sees
// occludes only where the segment meets it covered (common/cutout.glsl).
bool visibleFromShooter(vec3 image, uint k, int chart, vec3 receiver, vec3 normal) {
  const int size = textureSize(depth_map, 0).x / int(tiles);
  const ivec2 origin = ivec2(tileOrigin(k, tiles)) * size;
  const ivec2 px = clamp(ivec2(floor((image.xy * 0.5 + 0.5) * float(size))), ivec2(0),
                         ivec2(size - 1));
  const float threshold = image.z * (1.0 - depth_tolerance) - 1e-7;
  const bool clear = texelFetch(depth_map, origin + px, 0).r >= threshold;
  // A cut-out seen at the texel: the texel's centre met it covered, but the segment may pass
  // through an opening beside that (the mask's detail is finer than a texel's reach); the
  // segment test below decides, exactly, where the segment meets it.
  bool cut = false;
  if (!clear) {
    const uint seen = texelFetch(id_map, origin + px, 0).r;
#ifdef CUTOUTS
    cut = seen != 0xffffffffu && cutoutPossible(seen);
#endif
    if (!cut && (seen == 0xffffffffu || !(nextTo(triangles[seen].front_chart, chart) ||
                                          nextTo(triangles[seen].back_chart, chart)))) {
      return false;
    }
  }
  // The segment's ends lifted off their surfaces, as the CPU's shadow rays are.
  const vec3 from = receiver + normal * hemisphere.on_plane;
  const vec3 to = batch[k].position_f.xyz + batch[k].eye.xyz + hemisphere.normal * hemisphere.on_plane;
  const WatertightRay segment = makeWatertightRay(from, to - from);
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      const ivec2 q = clamp(px + ivec2(dx, dy), ivec2(0), ivec2(size - 1));
      const float depth = texelFetch(depth_map, origin + q, 0).r;
      if (depth >= threshold) continue;
      const uint id = texelFetch(id_map, origin + q, 0).r;
      const GpuProgressiveTriangle t = triangles[id];
      float hit, u, v;
      if (intersectTriangle(segment, t.p0, t.p1, t.p2, 1e-4, 1.0 - 1e-4, hit, u, v)) {
#ifdef CUTOUTS
        // A cut-out occludes only where the segment meets it covered (the depth pass's test).
        if (cutoutPossible(id) &&
            !cutoutStops(id, vec2(u, v), cutoutRayUniform(from, to - from, id))) {
          continue;
        }
#endif
        return false;
      }
    }
  }
  return true;
}

// Whether receiver r (its point in double: pr) and batch point k make a pair of this pass:
// in front of each other's planes (elements reflect on their own side), apart, and near (NEAR_PASS 1) or far
// (NEAR_PASS 0), and not local (stochastic radiosity's local operator's pairs). Near or far is
// decided in the CPU's precision: exact ties at d^2 = kNear^2 A are common on regular meshes.
bool isPair(dvec3 pr, GpuProgressiveElement r, vec3 nr, uint k) {
  const vec3 d = batch[k].position_f.xyz - r.position;
  const dvec3 dd = batch[k].position.xyz - pr;
  const double dd2 = dd.x * dd.x + dd.y * dd.y + dd.z * dd.z;
  const bool near = dd2 < double(near_factor) * double(near_factor) * batch[k].position.w;
  const bool local = dd2 < double(local_factor) * double(local_factor) * batch[k].position.w;
  return dot(d, d) > 0.0 && dot(nr, d) > 0.0 && dot(hemisphere.normal, d) < 0.0 &&
         near == (NEAR_PASS == 1) && !local;
}

// Visibility of receiver r from batch point k: the back projection of its point into the
// point's depth map and the Fig. 3 test (compiled out when visibility is off).
bool seenFrom(GpuProgressiveElement r, GpuProgressiveTriangle rt, uint k) {
#if VISIBILITY
  Hemisphere h = hemisphere;
  h.origin = batch[k].position_f.xyz + batch[k].eye.xyz;
  vec3 image;
  return backProject(h, rt, r.barycentric, image) &&
         visibleFromShooter(image, k, texel_chart[r.texel], r.position, r.normal);
#else
  return true;
#endif
}

#if NEAR_PASS
// Near pairs (across an edge, in a corner): Lambert's exact form factor to each piece of each of
// batch point k's elements, times their dB, as the CPU does (W m^-2).
vec3 gatherNear(GpuProgressiveElement r, vec3 nr, uint k) {
  vec3 sum = vec3(0.0);
  for (uint q = 0u; q < batch[k].members.y; ++q) {
    const GpuProgressiveElement m = elements[batch[k].members.x + q];
    const ivec2 mt = ivec2(int(m.texel % uint(atlas_width)), int(m.texel / uint(atlas_width)));
    const vec3 db = texelFetch(residual_map, mt, 0).rgb;
    float f = 0.0;
    for (uint piece = 0u; piece < m.piece_count; ++piece) {
      vec3 poly[8];
      for (int c = 0; c < 8; ++c) poly[c] = polygons[8u * (m.piece_first + piece) + uint(c)].xyz;
      f += pointToPolygonFormFactor(r.position, nr, poly);
    }
    // Stochastic radiosity (local_factor > 0) keeps a texel only when its form factor is
    // positive, as its CPU shot does: on a curved chart some pieces face away and count negative.
    sum += db * (local_factor > 0.0 ? max(f, 0.0) : f);
  }
  return sum;
}
#else
// Far pairs: eq. 2's disc (m = 1) times the point's mean dB, or nearer than kFar of its sizes
// (decided in the CPU's precision, as isPair does) Lambert's form factor to its pieces (W m^-2).
vec3 gatherFar(dvec3 pr, GpuProgressiveElement r, vec3 nr, uint k) {
  const dvec3 dd = batch[k].position.xyz - pr;
  const double dd2 = dd.x * dd.x + dd.y * dd.y + dd.z * dd.z;
  if (batch[k].pieces.y > 0u &&
      dd2 < double(far_factor) * double(far_factor) * batch[k].position.w) {
    float f = 0.0;
    for (uint piece = 0u; piece < batch[k].pieces.y; ++piece) {
      vec3 poly[8];
      for (int c = 0; c < 8; ++c) {
        poly[c] = point_polygons[8u * (batch[k].pieces.x + piece) + uint(c)].xyz;
      }
      f += pointToPolygonFormFactor(r.position, nr, poly);
    }
    return batch[k].residual.rgb * f;
  }
  const vec3 d = batch[k].position_f.xyz - r.position;
  const float d2 = dot(d, d);
  const float inv = inversesqrt(d2);
  const float cos_r = dot(nr, d) * inv, cos_s = -dot(hemisphere.normal, d) * inv;
  // The shading normal may face away where the face's normal (isPair's) does not: no light, as
  // on the CPU (a negative disc took light away).
  if (cos_r <= 0.0 || cos_s <= 0.0) return vec3(0.0);
  return batch[k].residual.rgb * discFormFactor(batch[k].position_f.w, cos_s, cos_r, d2);
}
#endif

void main() {
  const uint e = v_element;
  if (count_mode) {
    incident = vec4(1.0, 0.0, 0.0, 0.0);
    return;
  }
  const GpuProgressiveElement r = receivers[e];
  const GpuProgressiveTriangle rt = triangles[r.triangle];
#if SAMPLE_PASS
  incident = vec4(0.0);
  const uint j = e % sample_points;
  for (uint k = 0u; k < batch_count; ++k) {
    if (batch[k].members.z != j) continue;
    const vec3 d = batch[k].position_f.xyz - r.position;
    if (dot(d, d) > 0.0 && dot(r.normal, d) > 0.0 && dot(hemisphere.normal, d) < 0.0) {
      samples[e] = seenFrom(r, rt, k) ? 3u : 1u;
    }
  }
  return;
#endif
  const dvec3 pr = dvec3(receiver_position[3 * e], receiver_position[3 * e + 1],
                         receiver_position[3 * e + 2]);
  // This pass's pairs of the batch as a bit mask, then a loop over its set bits. A SIMD
  // rasteriser (llvmpipe) runs both sides of every branch under lane masks, but leaves a loop
  // as soon as no lane has work: the expensive part costs only what the pairs need.
  uint pairs = 0u;
  for (uint k = 0u; k < batch_count; ++k) {
    if (isPair(pr, r, r.normal, k)) pairs |= 1u << k;
  }
  vec3 sum = vec3(0.0);
  while (pairs != 0u) {
    const uint k = uint(findLSB(pairs));
    pairs &= pairs - 1u;
    if (!seenFrom(r, rt, k)) continue;
    // Culling took the face's normal; the cosine takes the shading normal (a normal map's,
    // Wallner sec. 3.3), as the CPU solver does.
#if NEAR_PASS
    sum += gatherNear(r, r.shading_normal, k);
#else
    sum += gatherFar(pr, r, r.shading_normal, k);
#endif
  }
  if (sum == vec3(0.0)) discard;  // nothing to add
  incident = vec4(sum, 0.0);
}
