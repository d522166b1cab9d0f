// THE GLSL TWIN of the luminaire lookup in src/penumbra/scene/luminaire.h (luminaireTexCoords,
// sampleLuminaireTable): Wallner sec. 3.2, the light distribution texture read at eq. 13-14's
// coordinates over the whole sphere. Same operations in the same order, in single precision;
// change both together (Lights.GlslTwinAgreesWithCpp checks them through sampleLight).
//
// The includer supplies `float luminaireTable(uint index)`: the tables buffer of gpuLights()
// (raytrace/lights.h), where a light's LDT starts at its `table` with gamma_count and c_count
// as floats, then c_count rows of gamma_count values.
#ifndef PENUMBRA_LUMINAIRE_GLSL
#define PENUMBRA_LUMINAIRE_GLSL

float luminaireTable(uint index);

// x_t = gamma / pi (eq. 13 over the whole sphere), y_t = C / 2 pi in [0, 1) (eq. 14).
vec2 luminaireTexCoords(vec3 d, vec3 nadir, vec3 c0) {
  const float kPi = 3.14159265358979;
  float cos_g = clamp(dot(d, nadir), -1.0, 1.0);
  float xt = acos(cos_g) / kPi;
  vec3 c90 = cross(c0, nadir);
  float phi = atan(dot(d, c90), dot(d, c0)) / (2.0 * kPi);
  if (phi < 0.0) phi += 1.0;
  return vec2(xt, phi >= 1.0 ? 0.0 : phi);
}

// Bilinear, clamped in gamma and wrapping in C (the paper's GL_REPEAT).
float sampleLuminaireTable(uint base, vec2 t) {
  int gamma_count = int(luminaireTable(base));
  int c_count = int(luminaireTable(base + 1u));
  uint rows = base + 2u;
  float g = clamp(t.x, 0.0, 1.0) * float(gamma_count - 1);
  int g0 = min(int(g), gamma_count - 2);
  float fg = g - float(g0);
  float c = t.y * float(c_count);
  int c_floor = int(floor(c));
  float fc = c - float(c_floor);
  int c0 = ((c_floor % c_count) + c_count) % c_count;
  int c1 = (c0 + 1) % c_count;
  uint r0 = rows + uint(c0 * gamma_count), r1 = rows + uint(c1 * gamma_count);
  float a0 = luminaireTable(r0 + uint(g0)), a1 = luminaireTable(r0 + uint(g0 + 1));
  float b0 = luminaireTable(r1 + uint(g0)), b1 = luminaireTable(r1 + uint(g0 + 1));
  float a = a0 + fg * (a1 - a0);
  float b = b0 + fg * (b1 - b0);
  return a + fc * (b - a);
}

#endif
