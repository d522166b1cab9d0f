#version 450
#include "subsurface/sss_bindings.glsl"
// Pass 1 of the subsurface method (Carr, Hall, Hart 2003, sec. 4.2.2) on the GPU: the irradiance
// transmitted into each element of a translucent object, E = sum over lights of
// F_t(eta, cos theta) E_light V (eq. 8) plus the static share (emitters, environment). The GPU
// twin of SssSolver::transmittedIrradiance (src/penumbra/subsurface/sss.cpp): the same light sample
// (common/lights.glsl), the same shadow ray, traced by the Ray Engine's BVH kernel
// (raytrace/bvh_intersect.comp) between the two programs this file makes:
//   SSS_PASS 0: per (element, light) the shadow ray and what it carries when unoccluded;
//   SSS_PASS 1: per element the sum over its lights of the unoccluded values.
#include "subsurface/sss_layout.glsl"
#include "raytrace/layout.glsl"
#include "common/dipole.glsl"
#include "common/lights.glsl"

layout(local_size_x = 64) in;

layout(std430, binding = SSS_SSBO_ELEMENTS) readonly buffer Elements { GpuSssElement elements[]; };
layout(std430, binding = SSS_SSBO_RAY_VALUES) buffer RayValues { vec4 ray_values[]; };

layout(std430, binding = SSS_SSBO_LIGHT_TABLES) readonly buffer LightTables { float tables[]; };
float luminaireTable(uint index) { return tables[index]; }

uniform uint element_count;
uniform uint light_count;

#if SSS_PASS == 0
layout(std430, binding = SSS_SSBO_LIGHTS) readonly buffer Lights { GpuLight lights[]; };
layout(std430, binding = SSS_SSBO_RAYS) writeonly buffer Rays { GpuRay rays[]; };

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= element_count * light_count) return;
  uint e = i / light_count;
  GpuSssElement el = elements[e];
  // A ray the kernel skips (tmin > tmax), and nothing to carry.
  GpuRay ray = GpuRay(vec3(0.0), 1.0, vec3(0.0, 0.0, 1.0), 0.0);
  vec3 value = vec3(0.0);
  if (el.eta > 0.0) {
    LightSample ls = sampleLight(lights[i % light_count], el.position, el.normal,
                                 el.shading_normal);
    if (ls.irradiance != vec3(0.0)) {
      bool far = ls.distance < 0.0;
      ray = GpuRay(el.position + el.normal * el.lift, 1e-4,
                   far ? ls.direction : ls.direction * ls.distance,
                   far ? 3.402823466e38 : 1.0 - 1e-4);
      // Eq. 8: the light that crosses the boundary.
      value = ls.irradiance * fresnelTransmittance(el.eta, dot(ls.direction, el.shading_normal));
    }
  }
  rays[i] = ray;
  ray_values[i] = vec4(value, 0.0);
}

#else
layout(std430, binding = SSS_SSBO_HITS) readonly buffer Hits { GpuHit hits[]; };
layout(std430, binding = SSS_SSBO_MEAN) writeonly buffer Irradiance { vec4 irradiance[]; };

void main() {
  uint e = gl_GlobalInvocationID.x;
  if (e >= element_count) return;
  GpuSssElement el = elements[e];
  vec3 sum = vec3(0.0);
  if (el.eta > 0.0) {
    for (uint k = e * light_count; k < (e + 1u) * light_count; ++k) {
      if (hits[k].triangle < 0) sum += ray_values[k].xyz;
    }
    sum += el.static_irradiance;
  }
  irradiance[e] = vec4(sum, 0.0);
}
#endif
