// The reference path tracer: unbiased Monte Carlo estimation of the rendering equation for
// Lambertian scenes (Kajiya 1986), with next-event estimation to emissive triangles and delta
// lights, multiple importance sampling of emitters against cosine-weighted BSDF sampling with
// the power heuristic (Veach 1997, ch. 9), and Russian roulette. Every radiosity method is
// judged against it, so it favours being right over being fast: shading uses geometric
// normals (interpolated normals are not physical), and nothing is clamped.
//
// Mirrors and smooth glass (Material::scattering, raytrace/specular.h) are delta BSDFs: a path
// follows one lobe (glass: reflection with the Fresnel probability F_r, else refraction) and
// takes no emitter sample there, so light reaches it through them only by the continuation
// finding an emitter or the environment (full weight). Delta lights seen only through a mirror or
// glass (a point light's caustic) therefore stay black here; the whitted and photons methods
// compute them.
//
// Translucent materials (Material::subsurface) are the physical reference for the dipole method
// (subsurface/): a smooth dielectric boundary (exact Fresnel, chosen stochastically) around a
// homogeneous medium filling the closed mesh, crossed by a random walk with isotropic
// scattering (medium_walk.h). The walk advances one event (a free flight ending in a scattering
// event or at the boundary) per call of PathTracer::shade, its rays traced by the same
// intersection queries as every bounce, so render() and renderWavefront() share it unchanged.
// No emitter sample is taken at the boundary (a delta BSDF) or inside the medium: light reaches
// the walk through its random continuation, and an emitter or the environment found after such
// an event counts with full weight. Media do not nest: the side of the last translucent
// boundary crossed says whether a path is inside.
//
// The uniform environment (Scene::environment) is gathered by rays that leave the scene, found
// by BSDF sampling only (no emitter sample for it): unbiased, and noise-free enough for the
// furnace and albedo tests it serves.
//
// Sampling: the pixel jitter and, at the first vertices of a path, the emitter sample, the
// bounce direction and Russian roulette take Owen-scrambled Sobol points (core/sobol.h), one
// pattern per decision and vertex, so the samples of a pixel stratify them jointly; everything
// else draws from a PCG stream.
//
// Determinism: sample s of pixel p draws from its own PCG stream (sampleRng) and its own index in
// its pixel's Sobol patterns, so any thread count and either way of advancing the paths (render,
// renderWavefront) gives the same image.
#pragma once

#include "penumbra/core/image.h"
#include "penumbra/core/rng.h"
#include "penumbra/raytrace/daylight_gather.h"
#include "penumbra/raytrace/direct_light.h"
#include "penumbra/raytrace/medium_walk.h"
#include "penumbra/raytrace/scene_geometry.h"
#include "penumbra/scene/scene.h"

#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>

namespace penumbra {

class CameraRays;

struct PathTracerSettings {
  int width = 512;
  int height = 512;
  int spp = 64;
  // Path vertices: bounces, and in translucent materials boundary and medium events too;
  // 0 = unlimited (Russian roulette ends paths).
  int max_depth = 0;
  int rr_start_depth = 3;  // Russian roulette from this vertex on
  uint64_t seed = 0;
  // True: the pixel jitter and the first vertices' decisions take Owen-scrambled Sobol points
  // (core/sobol.h); false: every sample draws from its own random stream alone.
  bool low_discrepancy = true;
  // False: a camera ray hitting a translucent boundary always refracts, weighted by the Fresnel
  // transmittance F_t, and never reflects, so the image shows only the light that left the
  // medium: what the dipole method models, for comparing the two.
  bool boundary_reflection_from_camera = true;
  // True: a path ends at its first diffuse vertex after that vertex's direct light (its emitter
  // samples, and one ray towards the environment), so the image holds only the light of
  // camera - (mirror | glass)* - diffuse - light paths and of light seen through mirrors and glass:
  // the light Whitted's method computes (raytrace/whitted.h), for comparing the two.
  bool direct_only = false;
};

// One path in flight: the ray to trace next and what the path has gathered. The path tracer's
// step (PathTracer::shade) is the same whether paths are traced one at a time or as a
// wavefront of batches, so both give the same image bit for bit.
struct PathState {
  Ray ray;
  glm::vec3 result{0.0f};       // radiance gathered so far
  glm::vec3 beta{1.0f};         // throughput of the current ray
  glm::vec3 vertex_beta{0.0f};  // throughput at the vertex the pending shadow queries left
  glm::vec3 prev_point{0.0f};
  float prev_pdf = 0.0f;  // solid-angle pdf of the last bounce; 0 for the camera ray
  int depth = 0;          // vertices so far: bounces, boundary events and medium events
  int medium = -1;        // material index of the medium the ray travels in; -1 outside
  int medium_events = 0;  // boundary and medium events (PathTracer::kMaxMediumEvents)
  bool specular = false;  // the last vertex took no emitter sample (smooth boundary, medium)
  int hero = -1;          // the channel that samples the free flights; drawn on entering a medium
  SpectralPathWeight spectral;  // the free flights' per-channel pdfs (medium_walk.h)
  bool alive = true;
  Rng rng;
  // Low-discrepancy samples (core/sobol.h) for the camera jitter and, at the first
  // PathTracer::kSobolDepths vertices, the emitter sample, the bounce and Russian roulette:
  // pattern seeds from `ld_key` (the pixel), points by the sample's index, kept bit-reversed
  // (the form the scrambling takes, reversed once per path rather than at every vertex). Off for
  // paths started by radiance() (their callers supply only a generator): those draw from `rng`.
  bool low_discrepancy = false;
  uint64_t ld_key = 0;
  uint32_t ld_reversed_index = 0;
};

// Batched ray queries for the wavefront path tracer: the CPU Ray Engine, the GPU kernel or the
// CPU/GPU split. Errors (a GPU failure) are returned as values.
class RayQueries {
 public:
  virtual ~RayQueries() = default;
  virtual Status intersect(const RayBatch& rays, HitBatch& hits) = 0;
  virtual Status occluded(const RayBatch& rays, std::vector<uint8_t>& occluded) = 0;
};

struct PathTracerStats {
  uint64_t rays = 0;  // primary, bounce and shadow rays
  double seconds = 0.0;
};

class PathTracer {
 public:
  // The scene must have passed validateScene.
  explicit PathTracer(const Scene& scene);

  // Other lights for the same geometry and materials (no BVH to build again).
  void setLights(std::span<const Light> lights) { lights_.assign(lights.begin(), lights.end()); }

  // One-sample estimate of the radiance arriving along `ray` (W m^-2 sr^-1): the radiance
  // leaving the first surface hit towards the ray origin. `rays` counts the rays traced.
  glm::vec3 radiance(const Ray& ray, Rng& rng, const PathTracerSettings& settings,
                     uint64_t& rays) const;

  // Renders the camera's view; `on_progress(rows_done)` is called, possibly from worker
  // threads and out of order, with the number of rows finished so far.
  Image render(const Camera& camera, const PathTracerSettings& settings,
               PathTracerStats* stats = nullptr,
               const std::function<void(int)>& on_progress = {}) const;

  // Rows [y0, y1) of render()'s image, bit for bit, into `rows` ((y1 - y0) x width, row-major);
  // `on_row()` after each row (from any thread). Returns the rays traced. What a rank of a
  // distributed render computes for each block of rows (cluster/distributed_render.h).
  uint64_t renderRows(const Camera& camera, const PathTracerSettings& settings, int y0, int y1,
                      std::span<glm::vec3> rows, const std::function<void()>& on_row = {}) const;

  // Sample `sample` (of settings.spp) of every pixel in rows [y0, y1), added to `sum` (one entry
  // per pixel of the whole image, row-major): the values render() sums. Adding samples 0 ..
  // spp - 1 in order and dividing by spp gives render()'s image bit for bit, which is how a
  // progressive preview accumulates it a slice at a time. Returns the rays traced.
  uint64_t addSamples(const Camera& camera, const PathTracerSettings& settings, int sample, int y0,
                      int y1, std::span<glm::dvec3> sum) const;

  // The same image as render(), with paths advanced as a wavefront: each bounce's rays, then
  // each bounce's shadow rays, go to `queries` as one batch (so any back end of the Ray Engine
  // can trace them). `on_progress(rows_done)` as in render().
  Expected<Image> renderWavefront(const Camera& camera, const PathTracerSettings& settings,
                                  RayQueries& queries, PathTracerStats* stats = nullptr,
                                  const std::function<void(int)>& on_progress = {}) const;

  // Rows [y0, y1) of renderWavefront()'s image into `rows`, as renderRows(); `on_rows(n)` when n
  // more rows are done. Returns the rays traced.
  Expected<uint64_t> renderRowsWavefront(const Camera& camera, const PathTracerSettings& settings,
                                         int y0, int y1, RayQueries& queries,
                                         std::span<glm::vec3> rows,
                                         const std::function<void(int)>& on_rows = {}) const;

  // One step of a path: processes the hit of s.ray (inside a medium, first the free flight,
  // which may end in a scattering event before the hit; then emission with its MIS weight, or
  // the environment on a miss), writes the direct-light shadow queries of this vertex to
  // `queries` (at most lightQueryCapacity(); the count is returned; resolve them with addDirect)
  // and samples the continuation (s.alive is false when the path ends).
  int shade(PathState& s, const Hit& hit, const PathTracerSettings& settings,
            ShadowQuery* queries) const;
  static void addDirect(PathState& s, const ShadowQuery* queries, const uint8_t* occluded,
                        int count);
  size_t lightQueryCapacity() const { return lights_.size() + 3; }

  // A guard against endless walks: a path ends after this many boundary and medium events.
  // Bias-free in practice: a walk of 10^5 events reaches about sqrt(10^5) = 300 mean free paths
  // from where it entered, and the share of light doing so in any medium the sss method models
  // is far below the noise of a render.
  static constexpr int kMaxMediumEvents = 100000;

  // The generator of sample `sample` of pixel `pixel`: its own PCG stream, so that samples can
  // run in any order.
  static Rng sampleRng(uint64_t seed, uint64_t pixel, uint64_t sample, int spp) {
    return Rng(mixBits(seed), pixel * uint64_t(spp) + sample);
  }

  // The path of sample `sample` of pixel (x, y): its generator, its low-discrepancy stream and
  // its camera ray through the jittered point of the pixel.
  PathState startPath(const CameraRays& cam, const PathTracerSettings& settings, int x, int y,
                      int sample) const;

  // Vertices (path depths) whose random decisions come from the low-discrepancy patterns;
  // deeper ones draw from the path's generator, where stratification no longer shows.
  static constexpr int kSobolDepths = 6;

  const SceneGeometry& geometry() const { return geometry_; }

 private:
  // Direct-light queries at surface point p (ray offset p_offset, normal n facing the outgoing
  // side, reflectance rho): one per delta light and one emitter sample, MIS-weighted against
  // BSDF sampling, its emitter and point taken from the 2-D point (u_light_x as a 32-bit
  // fraction, u_light_y). Each query's value is added when its shadow ray is unoccluded.
  // `mis` false: the emitter sample takes full weight (no bounce sample follows).
  int directQueries(const glm::vec3& p, float p_offset, const glm::vec3& n, const glm::vec3& rho,
                    uint32_t u_light_x, float u_light_y, bool mis, ShadowQuery* out) const;
  // A mirror or glass vertex (raytrace/specular.h): one lobe, chosen by its Fresnel share.
  void shadeSpecular(PathState& s, const Material& mat, uint32_t tri, const glm::vec3& p,
                     float p_offset, const PathTracerSettings& settings) const;

  // The walk's part of shade: the smooth boundary of a translucent material, and the free flight
  // of a ray inside a medium.
  void shadeBoundary(PathState& s, uint32_t tri, float cos_front, const glm::vec3& p,
                     float p_offset, const PathTracerSettings& settings) const;
  bool mediumFlight(PathState& s, const Hit& hit, const PathTracerSettings& settings) const;

  // Follows path `s` to its end; returns the radiance it gathered.
  glm::vec3 trace(PathState& s, const PathTracerSettings& settings, uint64_t& rays) const;

  // Sample s of pixel (x, y): its jittered camera ray and radiance.
  glm::dvec3 pixelSample(const CameraRays& cam, const PathTracerSettings& settings, int x, int y,
                         int s, uint64_t& rays) const;

  SceneGeometry geometry_;
  std::vector<Light> lights_;
  glm::vec3 environment_{0.0f};
  // Daylight (scene/sky.h): what a ray that leaves the scene sees instead of the environment,
  // through the glazing of the openings it crosses.
  // The sky and the openings: what escaping rays see, and the portals of next-event
  // estimation of the sky (portalQuery).
  OpeningLight daylight_;
  bool glazed_ = false;  // some opening is glazed: delta lights' shadow rays take its transmittance
  glm::vec3 escaped(const Ray& ray) const;
  // The portal sample at p (ray offset p_offset, normal n facing the outgoing side, reflectance
  // rho) from (u1, u2): a point on the openings (OpeningLight::portalPoint), a shadow query to
  // infinity along it carrying rho / pi L cos / pdf, MIS-weighted against cosine sampling when
  // `mis`. False when the point faces away or the ray crosses no opening.
  bool portalQuery(const glm::vec3& p, float p_offset, const glm::vec3& n, const glm::vec3& rho,
                   float u1, float u2, bool mis, ShadowQuery& out) const;
};

}  // namespace penumbra
