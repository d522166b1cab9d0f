// Binding points of the subsurface shaders: the one definition that the shaders (#include) and
// src/penumbra/subsurface/sss_gl.cpp (#include through the shaders/ include path) both use, so
// that a binding cannot differ between the two. Valid GLSL and C++.
#ifndef PENUMBRA_SSS_BINDINGS
#define PENUMBRA_SSS_BINDINGS

#define SSS_SSBO_ELEMENTS 0
#define SSS_SSBO_LIGHTS 1
#define SSS_SSBO_RAYS 2
#define SSS_SSBO_HITS 3
#define SSS_SSBO_RAY_VALUES 4
#define SSS_SSBO_NODES 5
#define SSS_SSBO_CHILDREN 6
#define SSS_SSBO_WAVE_NODES 7
#define SSS_SSBO_MEAN 8
#define SSS_SSBO_GRADIENT 9
#define SSS_SSBO_LINKS 10
#define SSS_SSBO_SCATTERED 11
#define SSS_SSBO_MOMENT_INVERSE 12
#define SSS_SSBO_LIGHT_TABLES 13

#endif
