// Binding points of the ray engine shaders: the one definition that the shaders
// (#include) and src/penumbra/raytrace/ray_engine_gl.cpp (#include through the shaders/ include path) both use, so
// that a binding cannot differ between the two. Valid GLSL and C++.
#ifndef PENUMBRA_RAY_ENGINE_BINDINGS
#define PENUMBRA_RAY_ENGINE_BINDINGS

#define RAY_ENGINE_SSBO_NODES 0
#define RAY_ENGINE_SSBO_TRIANGLES 1
#define RAY_ENGINE_SSBO_RAYS 2
#define RAY_ENGINE_SSBO_HITS 3
// Cut-outs (common/cutout.glsl): four buffers from here.
#define RAY_ENGINE_SSBO_CUTOUTS 4
#define RAY_ENGINE_TEXTURE_RAY_ORIGINS 0
#define RAY_ENGINE_TEXTURE_RAY_DIRECTIONS 1

#endif
