// Direct light at a diffuse surface point as shadow queries: what the path tracer's next-event
// estimation, Whitted's shadow rays and photon mapping's direct term share. A query's value is
// the radiance it adds towards the viewer (before the path's or ray's weight) when its shadow ray
// is unoccluded.
#pragma once

#include "penumbra/kernels/ray.h"
#include "penumbra/raytrace/scene_geometry.h"
#include "penumbra/scene/light.h"

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <limits>
#include <span>

namespace penumbra {

// A shadow ray and what it contributes (before the path throughput) when unoccluded; `trace`
// is false when the light point coincides with the surface point (always visible).
struct ShadowQuery {
  Ray ray;
  glm::vec3 value{0.0f};
  bool trace = true;
};

inline constexpr float kRayInfinity = std::numeric_limits<float>::infinity();

// Moves a surface point off its surface by `offset` (SceneGeometry::surfaceOffset) along the
// normal, to the side of `dir`.
inline glm::vec3 offsetOrigin(const glm::vec3& p, float offset, const glm::vec3& n,
                              const glm::vec3& dir) {
  return p + (glm::dot(n, dir) >= 0.0f ? offset : -offset) * n;
}

// A shadow ray from surface point p (lifted off its surface by p_offset along n) to `target`
// (stopping a little short, so that it does not hit the light's own surface), or none (always
// visible) when the target is at p.
ShadowQuery shadowTo(const glm::vec3& p, float p_offset, const glm::vec3& n,
                     const glm::vec3& target, const glm::vec3& value);

// One query per delta light at surface point p (normal n facing the outgoing side, Lambertian
// reflectance rho): f I cos / d^2 for point-like lights, f E cos for directional ones, geometric
// terms taken at p. Returns the count written to `out` (at most lights.size()).
int deltaLightQueries(std::span<const Light> lights, const glm::vec3& p, float p_offset,
                      const glm::vec3& n, const glm::vec3& rho, ShadowQuery* out);

// One sample of the emissive triangles (picked by power, SceneGeometry::pickEmitter, with the
// 32-bit fraction u_x; the point on it from (the pick's remainder, u_y)), its value
// f Le cos_s / pdf_light times `weight` (an MIS weight, or 1 / the sample count). False when the
// sample gives nothing (the scene has no emitter, or the point faces away).
bool emitterQuery(const SceneGeometry& g, const glm::vec3& p, float p_offset, const glm::vec3& n,
                  const glm::vec3& rho, uint32_t u_x, float u_y, bool mis, float weight,
                  ShadowQuery& out);

}  // namespace penumbra
