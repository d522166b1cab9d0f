// Photon mapping (Jensen 1996, "Global illumination using photon maps"; Jensen 2001, "Realistic
// Image Synthesis Using Photon Mapping"), the Ray Engine paper's fourth application (Carr, Hall,
// Hart 2002, sec. 5): photons shot from every light through the Ray Engine in batches, stored
// where they land on diffuse surfaces in two kd-trees, and a Whitted ray tracer (whitted.h) whose
// diffuse vertices add the light the photons carry.
//
// Pass 1, the photons (Jensen 2001, ch. 5):
//   - The global map: `photons` photons leave the lights (chosen by power: emissive triangles by
//     their power, cosine-distributed from a uniform point; point lights uniformly over the
//     sphere; spots over their cone; luminaires over the sphere weighted by their distribution;
//     directional lights and the environment from a disc covering the scene), each carrying
//     flux Phi = (emitted radiance or intensity x cos) / (pdf x photons). At every diffuse
//     surface a photon is stored, then continues with probability max(rho) by a cosine-weighted
//     bounce (Russian roulette, flux x rho / max(rho)); mirrors and glass reflect or refract it
//     by their Fresnel shares (specular.h).
//   - The caustic map: `caustic_photons` photons aimed at the bounding sphere of the mirrors and
//     glass (uniform over the cone it subtends from the light's point; for directional lights
//     and the environment, a disc covering it: Jensen's projection map, simplified to one
//     sphere), kept only for paths light (mirror | glass)+ diffuse, stored at that diffuse
//     surface.
//
// Pass 2, the image: at each diffuse vertex of the ray tree the outgoing radiance is
//   direct (shadow rays, whitted.h) + caustics (caustic map, cone filter k = 1.1, Jensen 2001
//   eq. 7.7) + indirect (final gather: `final_gather` cosine-distributed rays, each through
//   mirrors and glass to the first diffuse surface, where the global map's radiance is read).
// The gather's global-map radiance is precomputed at a quarter of the photons and looked up at
// the nearest one facing the same way (Christensen 1999). With final_gather = 0 the indirect part
// is the global map's estimate at the vertex itself from the photons that reached it through a
// diffuse bounce (so direct and caustic light are not counted twice).
//
// The density estimate: E(x) = sum Phi_p / (pi r^2) over the `gather_count` nearest photons within
// `gather_radius` that arrived on the side the normal faces (r the k-th distance, or the radius
// when fewer are found); L = rho / pi E.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/raytrace/path_tracer.h"
#include "penumbra/raytrace/scene_geometry.h"
#include "penumbra/raytrace/whitted.h"
#include "penumbra/scene/scene.h"

#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

namespace penumbra {

struct PhotonSettings {
  uint64_t photons = 200000;          // emitted for the global map
  uint64_t caustic_photons = 200000;  // emitted towards mirrors and glass for the caustic map
  int gather_count = 64;              // photons per density estimate
  float gather_radius = 0.0f;         // their largest distance, m; 0: 1% of the scene's diagonal
  int final_gather = 32;              // gather rays per diffuse vertex; 0: the global map directly
  int max_bounces = 32;               // photon path length cap (diffuse and specular events)
  uint64_t seed = 0;
};

// A photon where it landed.
struct Photon {
  glm::vec3 position{0.0f};
  glm::vec3 power{0.0f};        // flux, W
  glm::vec3 normal{0.0f};       // the surface's unit normal on the side it arrived from
  glm::vec3 reflectance{0.0f};  // of the surface (for the gather's precomputed radiance)
  bool indirect = false;        // it went through a diffuse bounce before landing here
};

// A kd-tree over photons (nanoflann) and its density estimates.
class PhotonMap {
 public:
  PhotonMap();
  ~PhotonMap();
  PhotonMap(PhotonMap&&) noexcept;
  PhotonMap& operator=(PhotonMap&&) noexcept;

  void build(std::vector<Photon> photons);
  const std::vector<Photon>& photons() const;
  size_t memoryBytes() const;

  // Irradiance (W m^-2) at x on the side of unit normal n from the k nearest photons within
  // r_max; `cone` applies Jensen's cone filter (k = 1.1); `indirect_only` counts only photons
  // that went through a diffuse bounce.
  glm::vec3 irradiance(const glm::vec3& x, const glm::vec3& n, int k, float r_max, bool cone,
                       bool indirect_only) const;

  // Christensen 1999: the outgoing radiance rho / pi E precomputed at every `stride`-th photon,
  // and the nearest such point within r_max facing the way of n (cos > 0.7); zero when none.
  void precomputeRadiance(int k, float r_max, int stride);
  glm::vec3 radiance(const glm::vec3& x, const glm::vec3& n, float r_max) const;

 private:
  struct Index;
  std::unique_ptr<Index> index_;
  std::unique_ptr<Index> radiance_index_;  // photons whose power holds the precomputed radiance
};

struct PhotonStats {
  uint64_t emitted = 0, caustic_emitted = 0;
  uint64_t stored = 0, caustic_stored = 0;
  uint64_t rays = 0;                // photon rays traced
  double seconds = 0.0;             // shooting and storing the photons
  double build_seconds = 0.0;       // the two kd-trees
  double precompute_seconds = 0.0;  // the gather's radiance at every fourth photon
};

struct PhotonMaps {
  PhotonMap global, caustic;
  float radius = 0.0f;  // the gather radius in use
};

// Pass 1: both maps, through `queries`; `on_progress(photons traced so far)` as batches finish.
Expected<PhotonMaps> shootPhotons(const Scene& scene, const SceneGeometry& geometry,
                                  const PhotonSettings& settings, RayQueries& queries,
                                  PhotonStats* stats = nullptr,
                                  const std::function<void(uint64_t)>& on_progress = {});

// Pass 2's diffuse shading for WhittedTracer::render: caustics and the indirect part (direct
// light comes from the tracer's shadow rays).
DiffuseShading photonShading(const SceneGeometry& geometry, const PhotonMaps& maps,
                             const PhotonSettings& settings, uint64_t* gather_rays = nullptr);

}  // namespace penumbra
