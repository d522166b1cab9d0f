// Binding points of the jacobi shaders: the one definition that the shaders
// (#include) and src/penumbra/radiosity/jacobi_gl.cpp (#include through the shaders/ include path) both use, so
// that a binding cannot differ between the two. Valid GLSL and C++.
#ifndef PENUMBRA_JACOBI_BINDINGS
#define PENUMBRA_JACOBI_BINDINGS

#define JACOBI_SSBO_MATRIX 0
#define JACOBI_SSBO_RADIOSITY 1
#define JACOBI_SSBO_PARTIALS 2
#define JACOBI_SSBO_ELEMENTS 3
#define JACOBI_SSBO_NEXT 4
#define JACOBI_SSBO_ROW_RESIDUAL 5
#define JACOBI_SSBO_RESULT 6

#endif
