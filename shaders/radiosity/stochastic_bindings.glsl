// Binding points of the stochastic radiosity shaders: the one definition that the shaders
// (#include) and src/penumbra/radiosity/stochastic_gl.cpp both use. Valid GLSL and C++.
#ifndef PENUMBRA_STOCHASTIC_BINDINGS
#define PENUMBRA_STOCHASTIC_BINDINGS

#define STOCHASTIC_SSBO_ITERATE 0
#define STOCHASTIC_SSBO_AREA 1
#define STOCHASTIC_SSBO_SUMS 2
#define STOCHASTIC_SSBO_CHILD_FIRST 3
#define STOCHASTIC_SSBO_ROOTS 4
#define STOCHASTIC_SSBO_SELECTION 5
#define STOCHASTIC_SSBO_ELEMENTS 6
#define STOCHASTIC_SSBO_SOURCE 7
#define STOCHASTIC_SSBO_AVERAGE 8
#define STOCHASTIC_SSBO_PARTIAL 9
#define STOCHASTIC_SSBO_LOCAL_FIRST 10
#define STOCHASTIC_SSBO_LOCAL 11
#define STOCHASTIC_SSBO_LOCAL_IN 12
#define STOCHASTIC_TEXTURE_INCIDENT 0

#endif
