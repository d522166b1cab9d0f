// THE GLSL TWIN of sampleLight() in src/penumbra/raytrace/lights.h: direct irradiance from a
// point, spot, directional light or luminaire at a surface point, before visibility. Same operations in
// the same order, in single precision; change both together (Lights.GlslTwinAgreesWithCpp checks
// that they agree).
#ifndef PENUMBRA_LIGHTS_GLSL
#define PENUMBRA_LIGHTS_GLSL

// LIGHT_POINT, LIGHT_SPOT, LIGHT_DIRECTIONAL and LIGHT_LUMINAIRE are GpuLightType's values,
// defined by the program's host from raytrace/lights.h (gpuLightDefines): written once, in C++.
#ifndef LIGHT_LUMINAIRE
#error "the LIGHT_* types come from gpuLightDefines() (raytrace/lights.h)"
#endif

#include "common/luminaire.glsl"

struct GpuLight {  // 64 bytes, mirrored by penumbra::GpuLight (raytrace/lights.h)
  vec3 position;    // point, spot and luminaire
  uint type;        // LIGHT_*
  vec3 direction;   // unit: a spot's axis, a directional light's travel, a luminaire's nadir
  float cos_outer;  // spot: cos of the outer cone angle
  vec3 value;       // intensity I (W/sr) for point and spot, irradiance E (W/m^2) for directional,
                    // the LDT's scale (W/sr per unit) for a luminaire
  float spot_scale; // spot: 1 / max(1e-3, cos inner - cos outer)
  vec3 c0;          // luminaire: the C = 0 direction
  uint table;       // luminaire: its LDT in the tables buffer (common/luminaire.glsl)
};

struct LightSample {
  vec3 irradiance;  // W m^-2 at the point, before visibility
  vec3 direction;   // unit, towards the light
  float distance;   // to the light; negative for a directional light (infinitely far)
};

LightSample sampleLight(GpuLight light, vec3 p, vec3 ng, vec3 ns) {
  LightSample s = LightSample(vec3(0.0), vec3(0.0), 0.0);
  if (light.type == LIGHT_DIRECTIONAL) {
    s.direction = -light.direction;
    s.distance = -1.0;
    if (dot(ng, s.direction) <= 0.0) return s;
    float cos_s = dot(ns, s.direction);
    if (cos_s > 0.0) s.irradiance = light.value * cos_s;
    return s;
  }
  vec3 d = light.position - p;
  float d2 = dot(d, d);
  if (!(d2 > 0.0)) return s;
  s.distance = sqrt(d2);
  s.direction = d / s.distance;
  if (dot(ng, s.direction) <= 0.0) return s;
  float cos_s = dot(ns, s.direction);
  if (cos_s <= 0.0) return s;
  vec3 intensity = light.value;
  if (light.type == LIGHT_SPOT) {
    // The KHR_lights_punctual fall-off (scene/light.h spotFalloff).
    float a = clamp((dot(light.direction, -s.direction) - light.cos_outer) * light.spot_scale,
                    0.0, 1.0);
    intensity *= a * a;
  } else if (light.type == LIGHT_LUMINAIRE) {
    // Wallner eq. 15: the LDT's intensity towards the receiver.
    intensity *= sampleLuminaireTable(light.table,
                                      luminaireTexCoords(-s.direction, light.direction, light.c0));
  }
  s.irradiance = intensity * cos_s / d2;
  return s;
}

#endif
