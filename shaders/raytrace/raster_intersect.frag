#version 450
#include "raytrace/bindings.glsl"
// Ray-triangle intersection in the fragment stage (Carr et al. 2002, sec. 4.3, eq. 1-8). Each
// fragment is one ray: its origin and direction come from the ray-origins and ray-directions
// textures at this pixel (sec. 4.1). The hit distance t replaces the fragment's depth, so the
// depth test keeps the nearest hit per ray: the t-buffer (sec. 4.2); the colour outputs carry
// the triangle id and, as the paper allows where supported, t and the barycentrics.
//
// Eq. 8 as printed, w = bc . (bo x d), has the opposite sign to eq. 6 and 7: with bo = bc + co
// and bc x bc = 0 it equals -(cb . (co x d)), minus the weight of a. The sign is restored here
// so that u, v, w are the three barycentrics (of b, c, a) times the same determinant.
//
// Departures from the paper, for the Ray Engine's contract: both faces are hit (all three
// barycentrics of one sign, not only non-negative), and depth is t divided by the ray's own far
// bound (the smaller of tmax and where it leaves the scene's box, in the directions texture's w)
// so that it lies in [0, 1] whatever the scene's scale.

layout(binding = RAY_ENGINE_TEXTURE_RAY_ORIGINS) uniform sampler2D ray_origins;     // xyz origin, w tmin
layout(binding = RAY_ENGINE_TEXTURE_RAY_DIRECTIONS) uniform sampler2D ray_directions;  // xyz direction, w far bound

flat in vec3 v_a;
flat in vec3 v_b;
flat in vec3 v_n;
flat in vec3 v_ab;
flat in vec3 v_ac;
flat in vec3 v_bc;
flat in int v_id;

layout(location = 0) out int out_id;
layout(location = 1) out vec4 out_tuv;

void main() {
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  vec4 o4 = texelFetch(ray_origins, pixel, 0);
  vec4 d4 = texelFetch(ray_directions, pixel, 0);
  vec3 o = o4.xyz, d = d4.xyz;
  float tmin = o4.w, far = d4.w;
  precise vec3 ao = o - v_a;                   // (1)
  precise vec3 bo = o - v_b;                   // (2)
  precise float nd = dot(v_n, d);
  if (nd == 0.0) discard;                      // parallel to the plane
  precise float t = -dot(v_n, ao) / nd;        // (3)
  precise vec3 aod = cross(ao, d);             // (4)
  precise vec3 bod = cross(bo, d);             // (5)
  precise float u = dot(v_ac, aod);            // (6): weight of b
  precise float v = -dot(v_ab, aod);           // (7): weight of c
  precise float w = -dot(v_bc, bod);           // (8): weight of a (see below)
  bool front = u >= 0.0 && v >= 0.0 && w >= 0.0;
  bool back = u <= 0.0 && v <= 0.0 && w <= 0.0;
  precise float sum = u + v + w;
  if (!(front || back) || sum == 0.0 || !(t >= tmin && t <= far)) discard;
  out_id = v_id;
  out_tuv = vec4(t, u / sum, v / sum, 1.0);
  // Scaled just below 1 so that a hit at the far bound still passes GL_LESS against the clear.
  gl_FragDepth = far > 0.0 ? (t / far) * 0.999999 : 0.0;
}
