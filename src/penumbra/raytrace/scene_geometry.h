// A scene flattened for ray tracing: one triangle list over all meshes, per-triangle material,
// the Ray Engine built over it, and the emitters prepared for sampling.
#pragma once

#include "penumbra/raytrace/ray_engine.h"
#include "penumbra/scene/scene.h"

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <cstdint>
#include <vector>

namespace penumbra {

struct SceneGeometry {
  std::vector<glm::vec3> positions;
  std::vector<glm::uvec3> triangles;
  std::vector<uint32_t> material_ids;
  std::vector<glm::vec3> normals;  // unit geometric normal per triangle (front = CCW side)
  std::vector<float> areas;        // m^2 per triangle
  std::vector<Material> materials;
  RayEngine engine;

  // Emissive triangles, picked with probability proportional to emitted power (luminance of
  // emission times area; a Lambertian emitter's power is pi * L * A).
  std::vector<uint32_t> emitters;
  std::vector<float> emitter_cdf;       // inclusive prefix sums, last = 1
  std::vector<float> emitter_pick_pdf;  // per triangle: probability of picking it (0 if not)
  float total_emitted_power = 0.0f;     // W, luminance-weighted

  static SceneGeometry build(const Scene& scene);

  // Index into `emitters` for u in [0, 1).
  uint32_t pickEmitter(float u) const;
  glm::vec3 point(uint32_t triangle, float b1, float b2) const {
    const glm::uvec3 t = triangles[triangle];
    return (1.0f - b1 - b2) * positions[t.x] + b1 * positions[t.y] + b2 * positions[t.z];
  }
  // How far to move a ray origin at point(triangle, b1, b2) along the unit normal so that the
  // ray cannot hit the triangle it starts on: the rounding error of point(), gamma(7)
  // (|b0 p0| + |b1 p1| + |b2 p2|) (pbrt-v4 sec. 6.8.4) projected on the normal, plus the error
  // of the intersection test itself, which computes vertices relative to the origin and so
  // carries about 2^-24 of the vertices' magnitude (64 ulps of margin).
  float surfaceOffset(uint32_t triangle, float b1, float b2) const {
    const glm::uvec3 t = triangles[triangle];
    const glm::vec3 &p0 = positions[t.x], &p1 = positions[t.y], &p2 = positions[t.z];
    const float b0 = 1.0f - b1 - b2;
    constexpr float kGamma7 = 7.0f * 0x1p-24f / (1.0f - 7.0f * 0x1p-24f);
    const glm::vec3 err =
        2.0f * kGamma7 * (glm::abs(b0 * p0) + glm::abs(b1 * p1) + glm::abs(b2 * p2));
    const glm::vec3 m = glm::max(glm::max(glm::abs(p0), glm::abs(p1)), glm::abs(p2));
    const float magnitude = std::max(std::max(m.x, m.y), std::max(m.z, 1e-6f));
    return glm::dot(glm::abs(normals[triangle]), err) + 64.0f * 0x1p-24f * magnitude;
  }
};

}  // namespace penumbra
