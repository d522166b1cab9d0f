// THE GLSL TWIN of sampleLight() in src/penumbra/radiosity/lights.h: direct irradiance from a
// point, spot or directional light at a surface point, before visibility. Same operations in
// the same order, in single precision; change both together (Lights.GlslTwinAgreesWithCpp checks
// that they agree).
#ifndef PENUMBRA_LIGHTS_GLSL
#define PENUMBRA_LIGHTS_GLSL

#define LIGHT_POINT 0u
#define LIGHT_SPOT 1u
#define LIGHT_DIRECTIONAL 2u

struct GpuLight {  // 48 bytes, mirrored by penumbra::GpuLight (radiosity/lights.h)
  vec3 position;    // point and spot
  uint type;        // LIGHT_*
  vec3 direction;   // unit: a spot's axis, the way a directional light travels
  float cos_outer;  // spot: cos of the outer cone angle
  vec3 value;       // intensity I (W/sr) for point and spot, irradiance E (W/m^2) for directional
  float spot_scale; // spot: 1 / max(1e-3, cos inner - cos outer)
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
  }
  s.irradiance = intensity * cos_s / d2;
  return s;
}

#endif
