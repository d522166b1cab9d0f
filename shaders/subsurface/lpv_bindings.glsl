// Binding points of the light propagation volume shaders: the one definition that the shaders
// (#include) and src/penumbra/subsurface/lpv_gl.cpp (#include through the shaders/ include path)
// both use, so that a binding cannot differ between the two. Valid GLSL and C++. Fields are one
// RGBA32F 3D texture per colour channel (the two SH bands of subsurface/lpv_sh.h), the channels
// of a field at three consecutive units.
#ifndef PENUMBRA_LPV_BINDINGS
#define PENUMBRA_LPV_BINDINGS

// Texture units (texelFetch), read only.
#define LPV_TEX_FROM 0    // the propagation field of the last step, units 0-2
#define LPV_TEX_SCALE 3   // the transfer factors (LpvTransfer::scale), units 3-5
#define LPV_TEX_CELLS 6   // R8UI: the cell's kind (LpvCell), 0 outside
#define LPV_TEX_ACCUMULATED 7  // the accumulation field, units 7-9 (shading)

// Image units, written.
#define LPV_IMAGE_TO 0           // the propagation field of this step, units 0-2
#define LPV_IMAGE_ACCUMULATED 3  // the accumulation field, units 3-5

// Storage buffers (shading).
#define LPV_SSBO_SAMPLES 0
#define LPV_SSBO_RADIANCE 1

#endif
