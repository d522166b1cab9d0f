// A scene flattened for ray tracing: one triangle list over all meshes, per-triangle material,
// the Ray Engine built over it, and the emitters prepared for sampling.
#pragma once

#include "penumbra/raytrace/ray_engine.h"
#include "penumbra/scene/scene.h"
#include "penumbra/scene/surface_textures.h"

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <vector>

namespace penumbra {

inline constexpr uint64_t kEmitterCdfOne = uint64_t(1) << 32;

struct EmitterPick {
  uint32_t index;
  float u;
};

// What a ray found at a hit, as the methods that follow mirrors and glass shade it (whitted.h,
// photon_map.h): the triangle, its material, the point with its ray-origin lift, the geometric
// normal, and the same normal turned towards the arriving ray.
struct SurfaceHit {
  uint32_t triangle = 0;
  const Material* material = nullptr;
  glm::vec3 point{0.0f};
  float offset = 0.0f;               // SceneGeometry::surfaceOffset
  glm::vec3 geometric_normal{0.0f};  // front = counter-clockwise side
  glm::vec3 normal{0.0f};            // facing the arriving ray
  glm::vec3 dir{0.0f};               // unit direction of the arriving ray
  bool front = false;                // it arrived on the front face
  // The material's reflectance and emission at the point, textures applied.
  glm::vec3 reflectance{0.0f};
  glm::vec3 emission{0.0f};
};

struct SceneGeometry {
  std::vector<glm::vec3> positions;
  std::vector<glm::uvec3> triangles;
  std::vector<uint32_t> material_ids;
  std::vector<glm::vec3> normals;  // unit geometric normal per triangle (front = CCW side)
  std::vector<float> areas;        // m^2 per triangle
  std::vector<Material> materials;
  // Textures, vertex colours and cut-outs per triangle (the engine's hit filter holds it too).
  std::shared_ptr<const SurfaceTextures> textures;
  RayEngine engine;

  // Emissive triangles, picked with probability proportional to emitted power (luminance of
  // emission times area; a Lambertian emitter's power is pi * L * A).
  std::vector<uint32_t> emitters;
  std::vector<uint64_t> emitter_cdf;         // inclusive prefix sums, times 2^32 (last = 2^32)
  std::vector<float> emitter_width_inverse;  // 1 / (cdf[k] - cdf[k - 1])
  std::vector<float> emitter_pick_pdf;       // per triangle: probability of picking it (0 if not)
  float total_emitted_power = 0.0f;          // W, luminance-weighted

  static SceneGeometry build(const Scene& scene);

  // The emitter for a uniform 32-bit fraction u: its index into `emitters`, and where u falls
  // within its interval of the CDF, itself a uniform number in [0, 1) independent of the choice
  // (so one 2-D point picks the emitter and a coordinate on it; its precision is 32 bits less
  // the bits the choice took, 24 at most).
  EmitterPick pickEmitter(uint32_t u) const {
    const auto it = std::upper_bound(emitter_cdf.begin(), emitter_cdf.end(), uint64_t(u));
    const size_t k = std::min(size_t(it - emitter_cdf.begin()), emitter_cdf.size() - 1);
    const uint64_t lo = k > 0 ? emitter_cdf[k - 1] : 0;
    const float within = float(uint64_t(u) - lo) * emitter_width_inverse[k];
    return {uint32_t(k), std::min(within, 1.0f - 0x1p-24f)};
  }
  // The reflectance at a hit (barycentrics b1, b2): the material's, or its textures' there.
  glm::vec3 reflectanceAt(uint32_t triangle, float b1, float b2) const {
    return textures->varies(triangle) ? textures->reflectance(triangle, glm::vec2(b1, b2))
                                      : materials[material_ids[triangle]].reflectance;
  }
  // The emitted radiance of a surface a ray stopped on.
  glm::vec3 emissionAt(uint32_t triangle, float b1, float b2) const {
    return textures->varies(triangle) ? textures->emission(triangle, glm::vec2(b1, b2))
                                      : materials[material_ids[triangle]].emission;
  }
  // The emitted radiance at a point sampled on an emitter (next-event estimation, photon
  // emission): emissionAt() times the chance the surface is there at all (zero in a cut-out's
  // hole, alpha on a partly covering surface).
  glm::vec3 emissionSampled(uint32_t triangle, float b1, float b2) const {
    if (!textures->varies(triangle) && !textures->isCutout(triangle)) {
      return materials[material_ids[triangle]].emission;
    }
    const glm::vec2 b(b1, b2);
    glm::vec3 le = textures->emission(triangle, b);
    if (textures->isCutout(triangle)) {
      const Material& m = materials[material_ids[triangle]];
      const float a = textures->alpha(triangle, b);
      le *= m.alpha_mode == AlphaMode::kMask ? (a >= m.alpha_cutoff ? 1.0f : 0.0f) : a;
    }
    return le;
  }
  glm::vec3 point(uint32_t triangle, float b1, float b2) const {
    const glm::uvec3 t = triangles[triangle];
    return (1.0f - b1 - b2) * positions[t.x] + b1 * positions[t.y] + b2 * positions[t.z];
  }
  // The surface `hit` (a hit, not a miss) of a ray travelling along `ray_dir`.
  SurfaceHit surfaceHit(const Hit& hit, const glm::vec3& ray_dir) const {
    SurfaceHit h;
    h.triangle = uint32_t(hit.triangle);
    h.material = &materials[material_ids[h.triangle]];
    h.point = point(h.triangle, hit.u, hit.v);
    h.offset = surface_offsets[h.triangle];
    h.geometric_normal = normals[h.triangle];
    h.dir = glm::normalize(ray_dir);
    h.front = glm::dot(h.geometric_normal, h.dir) < 0.0f;
    h.normal = h.front ? h.geometric_normal : -h.geometric_normal;
    h.reflectance = reflectanceAt(h.triangle, hit.u, hit.v);
    h.emission = emissionAt(h.triangle, hit.u, hit.v);
    return h;
  }
  // How far to move a ray origin on `triangle` along the unit normal so that the ray cannot hit
  // the triangle it starts on (surface_offsets).
  float surfaceOffset(uint32_t triangle) const { return surface_offsets[triangle]; }
  // Per triangle, a bound valid at every point of it: the rounding error of point(), gamma(7)
  // (|b0 p0| + |b1 p1| + |b2 p2|) <= gamma(7) max_i |p_i| componentwise (pbrt-v4 sec. 6.8.4),
  // projected on the normal, plus the error of the intersection test itself, which computes
  // vertices relative to the origin and so carries about 2^-24 of the vertices' magnitude (64
  // ulps of margin). One load instead of the barycentric bound's arithmetic at every vertex.
  std::vector<float> surface_offsets;
};

}  // namespace penumbra
