// The shooter selection stochastic radiosity's descent writes (radiosity/stochastic.comp, pass 2)
// and the host reads back: the twin of GpuStochasticSelection (src/penumbra/radiosity/
// stochastic_gl.h), 64 bytes in std430; tests/gpu/layout_test.cpp checks that the two agree.
#ifndef RADIOSITY_STOCHASTIC_LAYOUT_GLSL
#define RADIOSITY_STOCHASTIC_LAYOUT_GLSL

struct GpuStochasticSelection {
  uint element;
  uint found;  // 0 when nothing has weight
  double probability;
  double power;
  double pad;
  dvec4 value;  // the texel's radiosity B_j (W m^-2)
};

#endif
