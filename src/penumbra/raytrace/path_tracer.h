// The reference path tracer: unbiased Monte Carlo estimation of the rendering equation for
// Lambertian scenes (Kajiya 1986), with next-event estimation to emissive triangles and delta
// lights, multiple importance sampling of emitters against cosine-weighted BSDF sampling with
// the power heuristic (Veach 1997, ch. 9), and Russian roulette. Every radiosity method is
// judged against it, so it favours being right over being fast: shading uses geometric
// normals (interpolated normals are not physical), and nothing is clamped.
//
// Determinism: pixel p's samples come from PCG stream p of the seed, so any thread count gives
// the same image.
#pragma once

#include "penumbra/core/image.h"
#include "penumbra/core/rng.h"
#include "penumbra/raytrace/scene_geometry.h"
#include "penumbra/scene/scene.h"

#include <atomic>
#include <cstdint>
#include <functional>

namespace penumbra {

struct PathTracerSettings {
  int width = 512;
  int height = 512;
  int spp = 64;
  int max_depth = 0;       // bounces; 0 = unlimited (Russian roulette ends paths)
  int rr_start_depth = 3;  // Russian roulette from this bounce on
  uint64_t seed = 0;
};

struct PathTracerStats {
  uint64_t rays = 0;  // primary, bounce and shadow rays
  double seconds = 0.0;
};

class PathTracer {
 public:
  // The scene must have passed validateScene.
  explicit PathTracer(const Scene& scene);

  // One-sample estimate of the radiance arriving along `ray` (W m^-2 sr^-1): the radiance
  // leaving the first surface hit towards the ray origin. `rays` counts the rays traced.
  glm::vec3 radiance(const Ray& ray, Rng& rng, const PathTracerSettings& settings,
                     uint64_t& rays) const;

  // Renders the camera's view; `on_progress(rows_done)` is called as rows complete.
  Image render(const Camera& camera, const PathTracerSettings& settings,
               PathTracerStats* stats = nullptr,
               const std::function<void(int)>& on_progress = {}) const;

  const SceneGeometry& geometry() const { return geometry_; }

 private:
  // Radiance from the delta lights and one emitter sample at surface point p (ray offset
  // p_offset) with normal n (facing the outgoing side), reflectance rho; the emitter sample is
  // MIS-weighted against BSDF sampling.
  glm::vec3 directLight(const glm::vec3& p, float p_offset, const glm::vec3& n,
                        const glm::vec3& rho, Rng& rng, uint64_t& rays) const;

  // Whether `target` is seen from surface point p (lifted off its surface by p_offset along n).
  bool visible(const glm::vec3& p, float p_offset, const glm::vec3& n, const glm::vec3& target,
               uint64_t& rays) const;

  SceneGeometry geometry_;
  std::vector<Light> lights_;
};

}  // namespace penumbra
