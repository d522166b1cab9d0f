// Whitted ray tracing (Whitted 1980), the first application of the Ray Engine paper (Carr, Hall,
// Hart 2002, sec. 1 and 5: "classical ray tracing"): camera rays, recursive mirror reflection
// and glass refraction, and shadow rays to the lights at every diffuse surface they reach.
//
// The rays of a ray tree advance as a wavefront, one generation at a time, and every generation's
// rays, then its shadow rays, go to the Ray Engine as one batch (RayQueries: the CPU engine, the
// GPU kernel or the CPU/GPU split, the same image on each). Per node of the tree (a ray with the
// weight it carries to its pixel sample):
//   - a miss adds weight x environment; an emissive front face adds weight x emission;
//   - a mirror or glass surface (raytrace/specular.h) spawns a reflected and, for glass, a
//     refracted ray, weighted by the Fresnel shares (both followed, not chosen), up to
//     `max_depth` generations;
//   - a diffuse surface adds the direct light of every delta light (one shadow ray each), of the
//     emissive triangles (`light_samples` shadow rays, stratified over the emitters by power and
//     over their area) and of the environment (`light_samples` cosine-distributed rays towards
//     it), and ends the branch.
// So the image is the light of the paths camera (mirror | glass)* [diffuse] light, the light the
// path tracer computes with PathTracerSettings::direct_only; area lights and the environment are
// estimated by their shadow rays (soft shadows), delta lights exactly.
//
// A DiffuseShading hook adds radiance at the diffuse vertices (photon mapping's caustics and
// final gather, raytrace/photon_map.h), given each generation's vertices as one batch.
//
// Determinism: every node draws from its own PCG stream keyed by its place in its tree, and a
// generation's contributions are summed into the pixel samples in node order, so the image does
// not depend on the thread count; the back ends give the same image up to their last-bit
// differences in t.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/raytrace/path_tracer.h"
#include "penumbra/raytrace/scene_geometry.h"
#include "penumbra/scene/scene.h"

#include <cstdint>
#include <functional>
#include <span>

namespace penumbra {

struct WhittedSettings {
  int width = 512;
  int height = 512;
  int spp = 4;            // camera rays per pixel, stratified (pixelJitter; antialiasing)
  int max_depth = 8;      // mirror and glass generations after the camera ray
  int light_samples = 8;  // shadow rays per diffuse vertex to the emissive triangles (and to the
                          // environment); delta lights take one each
  uint64_t seed = 0;
};

// A diffuse surface point a ray tree reached, as the DiffuseShading hook sees it.
struct DiffuseVertex {
  glm::vec3 point{0.0f};
  float offset = 0.0f;     // ray-origin lift (SceneGeometry::surfaceOffset)
  glm::vec3 normal{0.0f};  // unit geometric normal facing the arriving ray
  glm::vec3 reflectance{0.0f};
  uint64_t key = 0;  // the node's stream key, for the hook's own random numbers
};

// Extra radiance leaving diffuse vertices towards the rays that found them (W m^-2 sr^-1), for a
// generation's vertices at once; tracing through `queries` as it needs. Errors end the render.
using DiffuseShading = std::function<Status(std::span<const DiffuseVertex> vertices,
                                            std::span<glm::vec3> radiance, RayQueries& queries)>;

struct WhittedStats {
  uint64_t rays = 0;         // camera, reflected and refracted rays
  uint64_t shadow_rays = 0;  // shadow rays (to lights, emitters and the environment)
  uint64_t diffuse_vertices = 0;
  double seconds = 0.0;
};

class WhittedTracer {
 public:
  // The scene must have passed validateScene.
  explicit WhittedTracer(const Scene& scene);

  const SceneGeometry& geometry() const { return geometry_; }

  // The camera's view through `queries`; `on_progress(rows_done)` after each wave of rows.
  Expected<Image> render(const Camera& camera, const WhittedSettings& settings, RayQueries& queries,
                         WhittedStats* stats = nullptr,
                         const std::function<void(int)>& on_progress = {},
                         const DiffuseShading& shading = {}) const;

  // Rows [y0, y1) of render()'s image into `rows` ((y1 - y0) x width, row-major), bit for bit;
  // `on_rows(n)` when n more rows are done. Adds to *stats.
  Status renderRows(const Camera& camera, const WhittedSettings& settings, int y0, int y1,
                    RayQueries& queries, std::span<glm::vec3> rows, WhittedStats& stats,
                    const std::function<void(int)>& on_rows = {},
                    const DiffuseShading& shading = {}) const;

  // The direct light at a diffuse vertex as shadow queries (at most directCapacity()): the delta
  // lights, `light_samples` emitter samples and `light_samples` environment rays, each already
  // divided by its sample count, drawn from `rng`. Resolve with the unoccluded ones' values.
  int directQueries(const DiffuseVertex& v, int light_samples, Rng& rng, ShadowQuery* out) const;
  size_t directCapacity(int light_samples) const {
    return lights_.size() + 2 * size_t(light_samples);
  }

 private:
  SceneGeometry geometry_;
  std::vector<Light> lights_;
  glm::vec3 environment_{0.0f};
};

}  // namespace penumbra
