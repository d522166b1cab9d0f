// Point, spot, directional lights and luminaires for the radiosity methods: the direct irradiance
// they give a surface point, the power they send into the scene, and rays from them (for the check
// that a shot is closed). Radiometric units (scene/light.h): intensity I in W sr^-1, directional
// irradiance E in W m^-2.
//
//  - Point: E = I cos(theta) / d^2 (the inverse-square cosine law), power 4 pi I.
//  - Spot: the same times the glTF KHR_lights_punctual cone fall-off
//      s(a) = clamp((cos a - cos outer) / (cos inner - cos outer), 0, 1)^2,
//    power 2 pi I integral_0^outer s(a) sin(a) da (integrated in closed form below).
//  - Luminaire: E = I(d) cos(theta) / d^2 with I(d) from its light distribution texture
//    (Wallner eq. 15, scene/luminaire.h), power the LDT's integral over the sphere.
//  - Directional: E cos(theta) for surfaces facing it, power E pi R^2 with R the radius of the
//    scene's bounding sphere (what crosses a disc that covers the scene).
// theta is measured from the receiver's shading normal; a receiver whose face (geometric
// normal) turns away from the light gets nothing.
#pragma once

#include "penumbra/accel/bounds.h"
#include "penumbra/core/rng.h"
#include "penumbra/kernels/ray.h"
#include "penumbra/scene/light.h"

#include <glm/vec3.hpp>

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace penumbra {

struct LightSample {
  glm::dvec3 irradiance{0.0};  // W m^-2 at the point, before visibility
  glm::dvec3 direction{0.0};   // unit, from the point towards the light
  double distance = 0.0;       // to the light (infinity for a directional light)
};

// Direct irradiance from `light` at `p` (geometric normal `ng`, shading normal `ns`).
LightSample sampleLight(const Light& light, const glm::dvec3& p, const glm::dvec3& ng,
                        const glm::dvec3& ns);

class RayEngine;

// The direct irradiance at `p` (unit normal `n`, the side lit) from every light, each times its
// visibility by one shadow ray through `engine`, the ends lifted off the surface by `lift`;
// adds the rays traced to *rays.
glm::dvec3 visibleIrradiance(const RayEngine& engine, double lift, std::span<const Light> lights,
                             const glm::dvec3& p, const glm::dvec3& n, uint64_t* rays = nullptr);

// ---- The GPU twin (shaders/common/lights.glsl): a light as its sampleLight reads it, std430 ----
// LIGHT_POINT, LIGHT_SPOT, LIGHT_DIRECTIONAL, LIGHT_LUMINAIRE of shaders/common/lights.glsl.
enum class GpuLightType : uint32_t { kPoint = 0, kSpot = 1, kDirectional = 2, kLuminaire = 3 };

// The light types as the #defines ("LIGHT_POINT 0u", ...) every program that includes
// shaders/common/lights.glsl is compiled with (gl::computeProgram's defines).
std::vector<std::string> gpuLightDefines();

struct GpuLight {  // 64 bytes
  float position[3];
  GpuLightType type;
  float direction[3];  // unit: a spot's axis, a directional light's travel, a luminaire's nadir
  float cos_outer;
  float value[3];  // intensity (point, spot), irradiance (directional), LDT scale (luminaire)
  float spot_scale;
  float c0[3];     // a luminaire's C = 0 direction
  uint32_t table;  // a luminaire's LDT: its offset in the tables buffer (gpuLights)
};
static_assert(sizeof(GpuLight) == 64 && offsetof(GpuLight, direction) == 16 &&
              offsetof(GpuLight, value) == 32 && offsetof(GpuLight, c0) == 48);

// A scene light as the GPU twin reads it (the parameters sampleLight uses, in float); a
// luminaire's LDT at `table_offset` of the tables buffer.
GpuLight gpuLight(const Light& light, uint32_t table_offset = 0);

// All `lights` for the GPU, and in `tables` the LDTs of their luminaires (each distribution
// once): at a light's `table`, gamma_count and c_count as floats, then the LDT's rows. Never
// empty (one 0 when there is no luminaire), so it can always be bound as a buffer.
std::vector<GpuLight> gpuLights(std::span<const Light> lights, std::vector<float>& tables);

// The power `light` sends into a scene within `bounds` (W per channel).
glm::dvec3 lightPower(const Light& light, const Bounds3& bounds);

// A ray leaving one of `lights` (chosen by power), distributed as its emission: uniform over the
// sphere for a point, within the cone by its fall-off for a spot, from a disc covering `bounds`
// for a directional light. False when the lights have no power.
bool lightProbeRay(std::span<const Light> lights, const Bounds3& bounds, Rng& rng, Ray& ray);

}  // namespace penumbra
