#include "penumbra/raytrace/path_tracer.h"

#include "penumbra/core/check.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/sobol.h"
#include "penumbra/core/timer.h"
#include "penumbra/kernels/dipole.h"
#include "penumbra/kernels/sampling.h"
#include "penumbra/raytrace/camera_rays.h"
#include "penumbra/raytrace/specular.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <variant>

namespace penumbra {

namespace {

constexpr float kInfinity = kRayInfinity;

// The Sobol patterns of a path (core/sobol.h): 0 is the pixel jitter; vertex d (its depth) has
// 1 + 3 d + slot, slot one of these. The light sample takes one 2-D pattern for both the choice
// of emitter and the point on it (SceneGeometry::pickEmitter), so that the samples of a pixel
// cover the emitters' surfaces as one stratified set; Russian roulette takes the first
// dimension of its own.
constexpr uint32_t kPatternLight = 0, kPatternBounce = 1, kPatternRoulette = 2;

// The random decisions of a surface vertex.
struct VertexSamples {
  uint32_t light_x;  // the emitter and the first coordinate on it, a 32-bit fraction
  float light_y;     // the second coordinate on it
  glm::vec2 bounce;  // the cosine-weighted direction
  float roulette;    // Russian roulette
};

// All of them at once: the vertex's Sobol patterns' points for this sample (in one 4-lane pass),
// or the generator's numbers when the path is too deep or has no patterns.
inline VertexSamples vertexSamples(PathState& s) {
  VertexSamples v;
  if (!s.low_discrepancy || s.depth >= PathTracer::kSobolDepths) {
    v.light_x = s.rng.nextU32();
    v.light_y = s.rng.uniform();
    v.bounce.x = s.rng.uniform();
    v.bounce.y = s.rng.uniform();
    v.roulette = s.rng.uniform();
    return v;
  }
  const uint32_t base = 1 + 3 * uint32_t(s.depth);
  const SobolPattern patterns[4] = {
      sobolPattern(s.ld_key, base + kPatternLight), sobolPattern(s.ld_key, base + kPatternBounce),
      sobolPattern(s.ld_key, base + kPatternRoulette), SobolPattern{}};
  SobolBits points[4];
  owenSobol2DBitsReversedX4(s.ld_reversed_index, patterns, points);
  v.light_x = points[kPatternLight].x;
  v.light_y = unitFloat(points[kPatternLight].y);
  v.bounce = {unitFloat(points[kPatternBounce].x), unitFloat(points[kPatternBounce].y)};
  v.roulette = unitFloat(points[kPatternRoulette].x);
  return v;
}

// Russian roulette after a boundary or medium event (unbiased): survive with probability
// max(beta) once the throughput has fallen below 1, as PBRT 4th ed. sec. 14.2.2 does in media.
// Unlike the surfaces' rule this never caps survival below 1: a walk in a medium of albedo near
// 1 takes thousands of events, and killing 1% of the paths at each would leave the few long
// survivors with weights of 0.99^-1000; such a walk ends by leaving the medium instead (or by
// absorption, which lowers beta). False when the path ends.
inline bool surviveWalkRoulette(PathState& s, const PathTracerSettings& settings) {
  if (s.depth + 1 < settings.rr_start_depth) return true;
  const float m = std::max({s.beta.x, s.beta.y, s.beta.z});
  if (!(m < 1.0f)) return true;
  if (s.rng.uniform() >= m) return false;
  s.beta /= m;
  return true;
}

}  // namespace

PathTracer::PathTracer(const Scene& scene)
    : geometry_(SceneGeometry::build(scene)),
      lights_(scene.lights),
      environment_(scene.environment),
      daylight_(scene),
      glazed_(anyGlazing(scene.openings)) {}

glm::vec3 PathTracer::escaped(const Ray& ray) const {
  if (!daylight_.hasSky()) return environment_;
  const glm::dvec3 d = glm::normalize(glm::dvec3(ray.dir));
  return daylight_.skyRadiance(d) *
         float(transmittanceThrough(daylight_.openings(), glm::dvec3(ray.origin), d));
}

bool PathTracer::portalQuery(const glm::vec3& p, float p_offset, const glm::vec3& n,
                             const glm::vec3& rho, float u1, float u2, bool mis,
                             ShadowQuery& out) const {
  const glm::dvec3 y = daylight_.portalPoint(u1, u2);
  const glm::dvec3 d = y - glm::dvec3(p);
  const double d2 = glm::dot(d, d);
  if (!(d2 > 0.0)) return false;
  const glm::vec3 wi(d / std::sqrt(d2));
  const float cos_s = glm::dot(n, wi);
  if (cos_s <= 0.0f) return false;
  const float pdf_light = float(daylight_.portalPdf(glm::dvec3(p), glm::dvec3(wi)));
  if (!(pdf_light > 0.0f)) return false;
  const glm::vec3 l = escaped(Ray{p, 0.0f, wi, kInfinity});
  if (l == glm::vec3(0.0f)) return false;
  const float w = mis ? powerHeuristic(pdf_light, cos_s * kInvPi) : 1.0f;
  out = ShadowQuery{Ray{offsetOrigin(p, p_offset, n, wi), 0.0f, wi, kRayInfinity},
                    rho * kInvPi * l * cos_s * w / pdf_light, true};
  return true;
}

int PathTracer::directQueries(const glm::vec3& p, float p_offset, const glm::vec3& n,
                              const glm::vec3& rho, uint32_t u_light_x, float u_light_y, bool mis,
                              ShadowQuery* out) const {
  int count = deltaLightQueries(lights_, p, p_offset, n, rho, out);
  // The lamps' and the sun's light through glazed openings (a sun patch behind a window): cut by
  // the glazing's transmittance at the angle it crosses.
  if (glazed_) {
    for (int i = 0; i < count; ++i) {
      const Ray& r = out[i].ray;
      out[i].value *= float(transmittanceThrough(daylight_.openings(), glm::dvec3(r.origin),
                                                 glm::dvec3(r.dir), double(r.tmax)));
    }
  }
  // One sample of the emissive triangles, MIS-weighted against cosine sampling.
  if (emitterQuery(geometry_, p, p_offset, n, rho, u_light_x, u_light_y, mis, 1.0f, out[count])) {
    ++count;
  }
  // One sample of the sky through the openings (portalQuery), its 2-D point the
  // emitter sample's rotated by a fixed offset (Cranley-Patterson): as well stratified, and not
  // the same point.
  if (daylight_.active()) {
    const float u1 = std::fmod(float(double(u_light_x) * 0x1p-32) + 0.5f, 1.0f);
    const float u2 = std::fmod(u_light_y + 0.6180339887f, 1.0f);
    if (portalQuery(p, p_offset, n, rho, std::min(u1, 1.0f - 0x1p-24f),
                    std::min(u2, 1.0f - 0x1p-24f), mis, out[count])) {
      ++count;
    }
  }
  return count;
}

bool PathTracer::mediumFlight(PathState& s, const Hit& hit,
                              const PathTracerSettings& settings) const {
  if (++s.medium_events > kMaxMediumEvents) {
    s.alive = false;
    return true;
  }
  const Subsurface& medium = *geometry_.materials[size_t(s.medium)].subsurface;
  // The reduced problem the dipole solves: isotropic scattering with sigma_s = sigma_s'.
  const glm::dvec3 sigma_s = medium.sigma_s_prime;
  const glm::dvec3 sigma_t = sigma_s + medium.sigma_a;
  // Walk rays have unit directions, so the hit distance is in metres. A miss (a ray that slipped
  // through a crack of the mesh) is an unbounded medium: the flight scatters.
  const double t_boundary = hit.hit() ? double(hit.t) : double(kInfinity);
  if (s.hero < 0) s.hero = std::min(int(s.rng.uniform() * 3.0f), 2);
  const FreeFlight f = sampleFreeFlight(sigma_t, sigma_s, t_boundary, s.hero, s.rng.uniform());
  // beta stays the MIS-weighted throughput f_c(path) / (1/3 sum_k p_k(path)) of every channel.
  s.beta *= glm::vec3(s.spectral.update(f.f, f.pdf));
  if (!f.scattered) return false;  // the boundary: shade handles the hit

  // A scattering event: a new direction from the isotropic phase function, whose value 1/(4 pi)
  // and pdf cancel.
  s.alive = false;
  if (settings.max_depth > 0 && s.depth >= settings.max_depth) return true;
  const glm::vec3 x = s.ray.origin + float(f.t) * s.ray.dir;
  const float u1 = s.rng.uniform(), u2 = s.rng.uniform();
  const glm::vec3 wi(sampleUniformSphere(u1, u2));
  s.specular = true;
  if (!surviveWalkRoulette(s, settings)) return true;
  s.ray = Ray{x, 0.0f, wi, kInfinity};
  ++s.depth;
  s.alive = true;
  return true;
}

void PathTracer::shadeBoundary(PathState& s, uint32_t tri, float cos_front, const glm::vec3& p,
                               float p_offset, const PathTracerSettings& settings) const {
  if (++s.medium_events > kMaxMediumEvents) return;
  const uint32_t material = geometry_.material_ids[tri];
  const double eta = geometry_.materials[material].subsurface->eta;
  // The side the ray comes from: the medium is behind the front (counter-clockwise) face.
  const bool from_outside = cos_front > 0.0f;
  const glm::dvec3 ng(geometry_.normals[tri]);
  const glm::dvec3 n = from_outside ? ng : -ng;  // faces the incoming ray
  const glm::dvec3 d = glm::normalize(glm::dvec3(s.ray.dir));
  const double n_i = from_outside ? 1.0 : eta, n_t = from_outside ? eta : 1.0;
  // Exact unpolarised Fresnel reflectance, total internal reflection included (PBRT 4th ed.
  // sec. 9.3; kernels/dipole.h).
  const double f_r = fresnelReflectance(n_i, n_t, std::fabs(double(cos_front)));
  bool reflect;
  if (s.depth == 0 && from_outside && !settings.boundary_reflection_from_camera) {
    reflect = false;
    s.beta *= float(1.0 - f_r);  // only the transmitted share, F_t
  } else {
    // Reflect with probability F_r, refract otherwise: the weight F / probability is 1.
    reflect = s.rng.uniform() < f_r;
  }
  glm::dvec3 wi;
  if (reflect || !refractDirection(d, n, n_i / n_t, wi)) {
    reflect = true;  // a refraction lost to rounding at the critical angle
    wi = reflectDirection(d, n);
  }
  // Radiance is not scaled by eta^2 on crossing (PBRT 4th ed. sec. 9.5): every path starts at
  // the camera and ends at an emitter or the environment, all outside (index 1), so the factors
  // of its crossings cancel.
  s.medium = (reflect != from_outside) ? int(material) : -1;
  s.specular = true;
  if (!surviveWalkRoulette(s, settings)) return;
  const glm::vec3 wf(wi);
  s.ray = Ray{offsetOrigin(p, p_offset, geometry_.normals[tri], wf), 0.0f, wf, kInfinity};
  s.prev_point = p;
  ++s.depth;
  s.alive = true;
}

void PathTracer::shadeSpecular(PathState& s, const Material& mat, uint32_t tri, const glm::vec3& p,
                               float p_offset, const PathTracerSettings& settings) const {
  const float u =
      (s.low_discrepancy && s.depth < kSobolDepths) ? vertexSamples(s).bounce.x : s.rng.uniform();
  SpecularLobe lobe;
  if (!sampleSpecular(mat, geometry_.normals[tri], s.ray.dir, u, lobe)) return;
  s.beta *= lobe.weight;
  s.specular = true;
  s.prev_point = p;
  // Russian roulette as on diffuse surfaces: survival capped at 0.99, so a path caught between
  // perfect mirrors ends.
  if (s.depth + 1 >= settings.rr_start_depth) {
    const float survive = std::min(std::max({s.beta.x, s.beta.y, s.beta.z}), 0.99f);
    if (s.rng.uniform() >= survive) return;
    s.beta /= survive;
  }
  s.ray =
      Ray{offsetOrigin(p, p_offset, geometry_.normals[tri], lobe.dir), 0.0f, lobe.dir, kInfinity};
  ++s.depth;
  s.alive = true;
}

int PathTracer::shade(PathState& s, const Hit& hit, const PathTracerSettings& settings,
                      ShadowQuery* queries) const {
  s.alive = false;
  // Inside a medium the free flight comes first: it may scatter before the hit.
  if (s.medium >= 0 && mediumFlight(s, hit, settings)) return 0;
  if (!hit.hit()) {
    // The ray left the scene: the uniform environment or the sky. Through an opening, after a
    // vertex that took a portal sample, weighted against it by the power heuristic.
    float w = 1.0f;
    if (daylight_.active() && !s.specular && s.prev_pdf > 0.0f) {
      const float pdf_portal = float(
          daylight_.portalPdf(glm::dvec3(s.prev_point), glm::normalize(glm::dvec3(s.ray.dir))));
      if (pdf_portal > 0.0f) w = powerHeuristic(s.prev_pdf, pdf_portal);
    }
    s.result += s.beta * escaped(s.ray) * w;
    return 0;
  }
  const uint32_t tri = uint32_t(hit.triangle);
  const Material& mat = geometry_.materials[geometry_.material_ids[tri]];
  const glm::vec3 ng = geometry_.normals[tri];
  const float cos_front = -glm::dot(ng, s.ray.dir) / glm::length(s.ray.dir);
  const glm::vec3 p = geometry_.point(tri, hit.u, hit.v);
  const float p_offset = geometry_.surfaceOffset(tri);

  // Emission reached by BSDF sampling (or seen directly), MIS-weighted against the emitter
  // sample taken at the previous vertex; with full weight after a vertex that took none.
  // An unlit surface shows its colour to the camera only (Material::unlit).
  if (mat.isEmissive() && cos_front > 0.0f && (!mat.unlit || s.depth == 0)) {
    float w = 1.0f;
    if (!s.specular && s.prev_pdf > 0.0f && geometry_.emitter_pick_pdf[tri] > 0.0f) {
      const glm::vec3 d = p - s.prev_point;
      const float pdf_light =
          geometry_.emitter_pick_pdf[tri] / geometry_.areas[tri] * glm::dot(d, d) / cos_front;
      w = powerHeuristic(s.prev_pdf, pdf_light);
    }
    s.result += s.beta * geometry_.emissionAt(tri, hit.u, hit.v) * w;
  }
  if (settings.max_depth > 0 && s.depth >= settings.max_depth) return 0;
  // Translucent: the smooth boundary of the medium; `reflectance` plays no part.
  if (mat.isTranslucent()) {
    shadeBoundary(s, tri, cos_front, p, p_offset, settings);
    return 0;
  }
  // Mirrors and glass (raytrace/specular.h): a delta BSDF, so no emitter sample.
  if (mat.isSpecular()) {
    shadeSpecular(s, mat, tri, p, p_offset, settings);
    return 0;
  }
  // One-sided surfaces (Material::two_sided false) have a black back face.
  if (!mat.two_sided && !(cos_front > 0.0f)) return 0;
  const glm::vec3 rho = geometry_.reflectanceAt(tri, hit.u, hit.v);
  if (rho == glm::vec3(0.0f)) return 0;

  // Surfaces reflect on both sides: shade with the normal facing the incoming ray.
  const glm::vec3 n = cos_front > 0.0f ? ng : -ng;
  s.vertex_beta = s.beta;
  // An opaque surface inside a medium (not a supported scene) takes no emitter sample: its
  // shadow rays would ignore the medium's attenuation; its bounce finds the light unbiased.
  const bool in_medium = s.medium >= 0;
  const VertexSamples u = vertexSamples(s);
  int count = 0;
  if (settings.direct_only) {
    // The path ends here with this vertex's direct light: the emitter samples with full weight
    // (no bounce follows to share it with) and, under an environment, one cosine-weighted ray
    // towards it (f cos / pdf = rho).
    count = directQueries(p, p_offset, n, rho, u.light_x, u.light_y, false, queries);
    if (environment_ != glm::vec3(0.0f)) {
      const glm::vec3 wi =
          Frame::fromNormal(n).toWorld(sampleCosineHemisphere(u.bounce.x, u.bounce.y));
      if (glm::dot(n, wi) > 0.0f) {
        queries[count++] = ShadowQuery{Ray{offsetOrigin(p, p_offset, n, wi), 0.0f, wi, kInfinity},
                                       rho * environment_, true};
      }
    }
    return count;
  }
  if (!in_medium) {
    count = directQueries(p, p_offset, n, rho, u.light_x, u.light_y, true, queries);
  }
  s.specular = in_medium;

  // Cosine-weighted bounce: f cos / pdf = rho.
  const glm::vec3 local = sampleCosineHemisphere(u.bounce.x, u.bounce.y);
  const glm::vec3 wi = Frame::fromNormal(n).toWorld(local);
  const float cos_s = glm::dot(n, wi);
  if (cos_s <= 0.0f) return count;
  s.beta *= rho;
  s.prev_pdf = cos_s * kInvPi;
  s.prev_point = p;

  // Russian roulette (unbiased): survive with probability min(max(beta), 0.99), so that even
  // reflectance 1 ends.
  if (s.depth + 1 >= settings.rr_start_depth) {
    const float survive = std::min(std::max({s.beta.x, s.beta.y, s.beta.z}), 0.99f);
    if (u.roulette >= survive) return count;
    s.beta /= survive;
  }
  s.ray = Ray{offsetOrigin(p, p_offset, n, wi), 0.0f, wi, kInfinity};
  ++s.depth;
  s.alive = true;
  return count;
}

void PathTracer::addDirect(PathState& s, const ShadowQuery* queries, const uint8_t* occluded,
                           int count) {
  glm::vec3 direct(0.0f);
  for (int i = 0; i < count; ++i) {
    if (!occluded[i]) direct += queries[i].value;
  }
  s.result += s.vertex_beta * direct;
}

glm::vec3 PathTracer::radiance(const Ray& primary, Rng& rng, const PathTracerSettings& settings,
                               uint64_t& rays) const {
  PathState s;
  s.ray = primary;
  s.rng = rng;
  const glm::vec3 result = trace(s, settings, rays);
  rng = s.rng;
  return result;
}

glm::vec3 PathTracer::trace(PathState& s, const PathTracerSettings& settings,
                            uint64_t& rays) const {
  // The shadow queries of a vertex: on the stack for scenes with few lights (no allocation per
  // path), on the heap otherwise.
  constexpr size_t kOnStack = 8;
  ShadowQuery stack_queries[kOnStack];
  uint8_t stack_occluded[kOnStack];
  std::vector<ShadowQuery> heap_queries;
  std::vector<uint8_t> heap_occluded;
  ShadowQuery* queries = stack_queries;
  uint8_t* occluded = stack_occluded;
  if (lightQueryCapacity() > kOnStack) {
    heap_queries.resize(lightQueryCapacity());
    heap_occluded.resize(lightQueryCapacity());
    queries = heap_queries.data();
    occluded = heap_occluded.data();
  }
  for (;;) {
    ++rays;
    const Hit hit = geometry_.engine.intersect(s.ray);
    const int count = shade(s, hit, settings, queries);
    for (int i = 0; i < count; ++i) {
      occluded[i] = 0;
      if (!queries[i].trace) continue;
      ++rays;
      occluded[i] = geometry_.engine.occluded(queries[i].ray) ? 1 : 0;
    }
    if (count > 0) addDirect(s, queries, occluded, count);
    if (!s.alive) break;
  }
  return s.result;
}

glm::dvec3 PathTracer::pixelSample(const CameraRays& cam, const PathTracerSettings& settings, int x,
                                   int y, int s, uint64_t& rays) const {
  PathState path = startPath(cam, settings, x, y, s);
  return glm::dvec3(trace(path, settings, rays));
}

PathState PathTracer::startPath(const CameraRays& cam, const PathTracerSettings& settings, int x,
                                int y, int sample) const {
  const uint64_t pixel = uint64_t(y) * uint64_t(settings.width) + uint64_t(x);
  PathState p;
  p.rng = sampleRng(settings.seed, pixel, uint64_t(sample), settings.spp);
  p.low_discrepancy = settings.low_discrepancy;
  p.ld_key = pixelPatternKey(settings.seed, pixel);
  p.ld_reversed_index = reverseBits32(uint32_t(sample));
  if (!p.low_discrepancy) {
    const float jx = p.rng.uniform(), jy = p.rng.uniform();
    p.ray = cam.ray(float(x) + jx, float(y) + jy);
    return p;
  }
  const SobolBits jitter = owenSobol2DBitsReversed(p.ld_reversed_index, sobolPattern(p.ld_key, 0));
  p.ray = cam.ray(float(x) + unitFloat(jitter.x), float(y) + unitFloat(jitter.y));
  return p;
}

uint64_t PathTracer::addSamples(const Camera& camera, const PathTracerSettings& settings,
                                int sample, int y0, int y1, std::span<glm::dvec3> sum) const {
  PENUMBRA_CHECK(sum.size() == size_t(settings.width) * size_t(settings.height));
  const CameraRays cam(camera, settings.width, settings.height);
  std::atomic<uint64_t> total{0};
  parallelRange(size_t(y1 - y0), 1, [&](size_t r0, size_t r1) {
    uint64_t rays = 0;
    for (size_t r = r0; r < r1; ++r) {
      const int y = y0 + int(r);
      for (int x = 0; x < settings.width; ++x) {
        sum[size_t(y) * size_t(settings.width) + size_t(x)] +=
            pixelSample(cam, settings, x, y, sample, rays);
      }
    }
    total += rays;
  });
  return total.load();
}

uint64_t PathTracer::renderRows(const Camera& camera, const PathTracerSettings& settings, int y0,
                                int y1, std::span<glm::vec3> rows,
                                const std::function<void()>& on_row) const {
  PENUMBRA_CHECK(0 <= y0 && y0 <= y1 && y1 <= settings.height &&
                 rows.size() == size_t(y1 - y0) * size_t(settings.width));
  const CameraRays cam(camera, settings.width, settings.height);
  std::atomic<uint64_t> total_rays{0};
  const auto pixel = [&](size_t r, int x, uint64_t& rays) {
    throwIfInterrupted();  // a caller of the library asked to stop (core/interrupt.h)
    glm::dvec3 sum(0.0);
    for (int s = 0; s < settings.spp; ++s)
      sum += pixelSample(cam, settings, x, y0 + int(r), s, rays);
    rows[r * size_t(settings.width) + size_t(x)] = glm::vec3(sum / double(settings.spp));
  };
  const size_t count = size_t(y1 - y0);
  if (count >= size_t(threadCount())) {
    // Rows in parallel.
    parallelRange(count, 1, [&](size_t r0, size_t r1) {
      uint64_t rays = 0;
      for (size_t r = r0; r < r1; ++r) {
        for (int x = 0; x < settings.width; ++x) pixel(r, x, rays);
        if (on_row) on_row();
      }
      total_rays += rays;
    });
  } else {
    // Fewer rows than threads (a distributed render's small blocks): pixels in parallel. Each
    // pixel's value is its own either way.
    const size_t w = size_t(settings.width);
    parallelRange(count * w, 16, [&](size_t b, size_t e) {
      uint64_t rays = 0;
      for (size_t i = b; i < e; ++i) pixel(i / w, int(i % w), rays);
      total_rays += rays;
    });
    if (on_row) {
      for (size_t r = 0; r < count; ++r) on_row();
    }
  }
  return total_rays.load();
}

Image PathTracer::render(const Camera& camera, const PathTracerSettings& settings,
                         PathTracerStats* stats,
                         const std::function<void(int)>& on_progress) const {
  Timer timer;
  Image image(settings.width, settings.height);
  std::atomic<int> rows_done{0};
  const uint64_t rays = renderRows(camera, settings, 0, settings.height, image.pixels, [&] {
    const int done = rows_done.fetch_add(1) + 1;
    if (on_progress) on_progress(done);
  });
  if (stats) {
    stats->rays = rays;
    stats->seconds = timer.seconds();
  }
  return image;
}

}  // namespace penumbra

namespace penumbra {

Expected<Image> PathTracer::renderWavefront(const Camera& camera,
                                            const PathTracerSettings& settings, RayQueries& queries,
                                            PathTracerStats* stats,
                                            const std::function<void(int)>& on_progress) const {
  Timer timer;
  Image image(settings.width, settings.height);
  int rows_done = 0;
  Expected<uint64_t> rays =
      renderRowsWavefront(camera, settings, 0, settings.height, queries, image.pixels, [&](int n) {
        rows_done += n;
        if (on_progress) on_progress(rows_done);
      });
  if (!rays) return rays.error();
  if (stats) {
    stats->rays = *rays;
    stats->seconds = timer.seconds();
  }
  return image;
}

Expected<uint64_t> PathTracer::renderRowsWavefront(const Camera& camera,
                                                   const PathTracerSettings& settings, int y_begin,
                                                   int y_end, RayQueries& queries,
                                                   std::span<glm::vec3> rows,
                                                   const std::function<void(int)>& on_rows) const {
  PENUMBRA_CHECK(0 <= y_begin && y_begin <= y_end && y_end <= settings.height &&
                 rows.size() == size_t(y_end - y_begin) * size_t(settings.width));
  const CameraRays cam(camera, settings.width, settings.height);
  const size_t spp = size_t(settings.spp);
  const size_t cap = lightQueryCapacity();
  // Whole rows per wave, about 2^20 paths.
  const size_t rows_per_wave =
      std::max<size_t>(1, (size_t(1) << 20) / (size_t(settings.width) * spp));
  uint64_t rays = 0;
  std::vector<PathState> paths;
  std::vector<ShadowQuery> shadow;
  std::vector<int> shadow_count;
  std::vector<uint32_t> alive;
  RayBatch batch;
  HitBatch hits;
  std::vector<uint8_t> occluded;
  std::vector<size_t> shadow_slot;
  std::vector<uint8_t> blocked;  // per query slot: its shadow ray was occluded
  for (size_t y0 = size_t(y_begin); y0 < size_t(y_end); y0 += rows_per_wave) {
    const size_t y1 = std::min(size_t(y_end), y0 + rows_per_wave);
    const size_t n = (y1 - y0) * size_t(settings.width) * spp;
    paths.assign(n, PathState{});
    parallelRange(n, 1024, [&](size_t b, size_t e) {
      for (size_t i = b; i < e; ++i) {
        const size_t local_pixel = i / spp, s = i % spp;
        const size_t x = local_pixel % size_t(settings.width);
        const size_t y = y0 + local_pixel / size_t(settings.width);
        paths[i] = startPath(cam, settings, int(x), int(y), int(s));
      }
    });
    alive.resize(n);
    for (size_t i = 0; i < n; ++i) alive[i] = uint32_t(i);
    shadow.resize(n * cap);
    shadow_count.assign(n, 0);
    blocked.assign(n * cap, 0);
    while (!alive.empty()) {
      throwIfInterrupted();  // a caller of the library asked to stop (core/interrupt.h)
      // 1. This bounce's rays, as one batch.
      batch.resize(alive.size());
      for (size_t k = 0; k < alive.size(); ++k) batch.set(k, paths[alive[k]].ray);
      PENUMBRA_TRY(queries.intersect(batch, hits));
      rays += alive.size();
      // 2. Shade every path: emission, shadow queries, continuation.
      parallelRange(alive.size(), 256, [&](size_t b, size_t e) {
        for (size_t k = b; k < e; ++k) {
          const uint32_t i = alive[k];
          shadow_count[i] = shade(paths[i], hits.get(k), settings, &shadow[size_t(i) * cap]);
        }
      });
      // 3. The shadow rays, as one batch.
      shadow_slot.clear();
      for (uint32_t i : alive) {
        for (int q = 0; q < shadow_count[i]; ++q) {
          if (shadow[size_t(i) * cap + size_t(q)].trace) {
            shadow_slot.push_back(size_t(i) * cap + size_t(q));
          }
        }
      }
      batch.resize(shadow_slot.size());
      for (size_t k = 0; k < shadow_slot.size(); ++k) batch.set(k, shadow[shadow_slot[k]].ray);
      PENUMBRA_TRY(queries.occluded(batch, occluded));
      rays += shadow_slot.size();
      for (size_t k = 0; k < shadow_slot.size(); ++k) blocked[shadow_slot[k]] = occluded[k];
      parallelRange(alive.size(), 256, [&](size_t b, size_t e) {
        for (size_t k = b; k < e; ++k) {
          const uint32_t i = alive[k];
          if (shadow_count[i] > 0) {
            addDirect(paths[i], &shadow[size_t(i) * cap], &blocked[size_t(i) * cap],
                      shadow_count[i]);
          }
        }
      });
      for (size_t slot : shadow_slot) blocked[slot] = 0;  // clean for the next bounce
      // 4. Paths that go on.
      size_t kept = 0;
      for (uint32_t i : alive) {
        if (paths[i].alive) alive[kept++] = i;
      }
      alive.resize(kept);
    }
    // Pixels: samples summed in order, as render() does.
    for (size_t local_pixel = 0; local_pixel < n / spp; ++local_pixel) {
      glm::dvec3 sum(0.0);
      for (size_t s = 0; s < spp; ++s) sum += glm::dvec3(paths[local_pixel * spp + s].result);
      const size_t x = local_pixel % size_t(settings.width);
      const size_t y = y0 + local_pixel / size_t(settings.width);
      rows[(y - size_t(y_begin)) * size_t(settings.width) + x] =
          glm::vec3(sum / double(settings.spp));
    }
    if (on_rows) on_rows(int(y1 - y0));
  }
  return rays;
}

}  // namespace penumbra
