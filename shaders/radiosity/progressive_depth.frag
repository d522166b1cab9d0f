#version 450
#include "radiosity/progressive_bindings.glsl"
// The depth pass writes the depth of progressive_depth.vert (Algorithm 1's linear depth) and
// which triangle is nearest, so that the receiver pass can tell its own surface seen at a
// grazing angle from an occluder in front of it. With cut-outs (compiled with
// CUTOUT_SSBO_FIRST), a fragment where the surface is a hole is discarded, so the depth map
// holds the nearest surface that stops light, as the CPU's shadow rays see it; a partly
// covering one stops with probability alpha, decided per fragment and shooter point.
#include "common/cutout.glsl"

flat in uint v_triangle;
in vec2 v_param;
flat in vec3 v_origin;
layout(location = 0) out uint triangle_id;

void main() {
#ifdef CUTOUTS
  if (cutoutPossible(v_triangle) &&
      !cutoutStops(v_triangle, v_param,
                   cutoutRayUniform(v_origin, vec3(gl_FragCoord.xy, 0.0), v_triangle))) {
    discard;
  }
#endif
  triangle_id = v_triangle;
}
