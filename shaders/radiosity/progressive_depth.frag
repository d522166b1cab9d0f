#version 450
#include "radiosity/progressive_bindings.glsl"
// The depth pass writes the depth of progressive_depth.vert (Algorithm 1's linear depth) and
// which triangle is nearest, so that the receiver pass can tell its own surface seen at a
// grazing angle from an occluder in front of it.
flat in uint v_triangle;
layout(location = 0) out uint triangle_id;

void main() { triangle_id = v_triangle; }
