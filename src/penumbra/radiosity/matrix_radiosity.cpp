#include "penumbra/radiosity/matrix_radiosity.h"

#include "penumbra/core/check.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/core/timer.h"
#include "penumbra/kernels/sampling.h"
#include "penumbra/radiosity/outside_light.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <numbers>
#include <span>

namespace penumbra {

namespace {

// Bytes per lightmap element while the surface is built and solved (atlas, hierarchy, materials,
// direct term, interpolation): progressive radiosity measured 347-401 with its own buffers
// (docs/performance.md); 500 leaves a margin.
constexpr uint64_t kSurfaceBytesPerElement = 500;

// The lightmap has several elements per cluster (so that the cut can be chosen freely).
LightmapResolution lightmapFor(const MatrixRadiosityOptions& options) {
  LightmapResolution res = options.lightmap;
  res.elements = std::max<uint32_t>(
      res.elements, uint32_t(std::min<uint64_t>(uint64_t(options.elements) * 4, 1u << 30)));
  return res;
}

}  // namespace

namespace {

// The memory check of the system, on one process or for one rank's rows.
Status checkSystemMemory(uint64_t n, MatrixPrecision precision, int ranks, uint64_t elements) {
  const uint64_t rows = (n + uint64_t(ranks) - 1) / uint64_t(ranks);
  return checkMemory(
      matrixRadiosityBytes(n, precision, rows),
      ranks > 1
          ? fmt::format("matrix radiosity with {} elements ({} form factors; {} rows on "
                        "each of {} ranks)",
                        elements, n * n, rows, ranks)
          : fmt::format("matrix radiosity with {} elements ({} form factors)", elements, n * n));
}

// The sub-cluster rays of the file comment: per element, kSubClusterRays cosine-distributed rays
// (stratified 4 x 4, each element's own stream) of one size of the element's cluster; near_hit
// holds, per ray, kFree when it travelled that far without a hit, else the element it landed
// on (-1: none, a black back face). Elements that are clusters of their own trace none (all
// kFree). Adds the rays traced to *rays.
void traceSubClusterRays(const RadiositySurface& surface, std::span<const ClusterRef> clusters,
                         uint64_t seed, std::vector<int32_t>& near_hit, uint64_t* rays) {
  near_hit.assign(surface.elementCount() * kSubClusterRays, MatrixRadiosity::kFree);
  std::atomic<uint64_t> traced{0};
  parallelRange(clusters.size(), 16, [&](size_t begin, size_t end) {
    RayBatch batch;
    HitBatch hits;
    uint64_t count = 0;
    for (size_t k = begin; k < end; ++k) {
      const ClusterRef c = clusters[k];
      if (c.level == 0) continue;
      const uint32_t first = surface.hierarchy.elementBegin(c);
      const uint32_t last = surface.hierarchy.elementEnd(c);
      const float reach = float(std::sqrt(surface.hierarchy.level(c.level).area[c.index]));
      constexpr int kSide = 4;
      static_assert(kSide * kSide == kSubClusterRays);
      batch.resize(size_t(last - first) * kSubClusterRays);
      for (uint32_t e = first; e < last; ++e) {
        const Frame frame = Frame::fromNormal(glm::vec3(surface.atlas.element_normal[e]));
        const glm::vec3 origin(surface.atlas.element_position[e] +
                               surface.atlas.element_normal[e] * surface.lift);
        Rng rng(mixBits(seed ^ 0x5c1u), e);
        for (int r = 0; r < kSubClusterRays; ++r) {
          const float u1 = (float(r % kSide) + rng.uniform()) / float(kSide);
          const float u2 = (float(r / kSide) + rng.uniform()) / float(kSide);
          batch.set(size_t(e - first) * kSubClusterRays + size_t(r),
                    Ray{origin, 0.0f, frame.toWorld(sampleCosineHemisphere(u1, u2)), reach});
        }
      }
      surface.engine.intersectSerial(batch, hits);
      count += batch.size();
      for (size_t i = 0; i < batch.size(); ++i) {
        if (hits.triangle[i] < 0) continue;
        near_hit[size_t(first) * kSubClusterRays + i] =
            surface.elementAtHit(hits.triangle[i], hits.u[i], hits.v[i],
                                 glm::vec3(batch.dx[i], batch.dy[i], batch.dz[i]));
      }
    }
    traced += count;
  });
  if (rays) *rays += traced.load();
}

}  // namespace

Status checkMatrixRadiosity(const Scene& scene, const MatrixRadiosityOptions& options, int ranks) {
  if (options.elements == 0) return inputError("", "--elements", "must be at least 1");
  const uint64_t n_max = options.elements + 3;  // cut(n) gives at most n + 3 clusters
  PENUMBRA_TRY(checkSystemMemory(n_max, options.precision, ranks, options.elements));
  // The lightmap has several elements per cluster (so that the cut can be chosen freely).
  const LightmapResolution res = lightmapFor(options);
  const uint64_t texels = expectedLightmapElements(scene, res);
  if (Status fits = checkMemory(texels * kSurfaceBytesPerElement,
                                fmt::format("a lightmap of {} texels", texels));
      !fits) {
    Error e = fits.error();
    e.place = res.texel_density ? "--texel-density" : res.size ? "--lightmap-size" : "--elements";
    return e;
  }
  Expected<ChartAtlasOptions> ao = lightmapAtlasOptions(scene, res);
  if (!ao) return ao.error();
  return {};
}

uint64_t matrixRadiosityBytes(uint64_t n, MatrixPrecision precision, uint64_t rows) {
  rows = std::min(rows, n);
  const uint64_t stored = rows * n * (precision == MatrixPrecision::kFp32 ? 4 : 2);
  // Over several ranks the entries bound for other ranks wait in buffers until the exchange:
  // at most as many as this rank's own rows hold.
  const uint64_t computed =
      (precision == MatrixPrecision::kFp32 ? 0 : rows * n * 4) + (rows < n ? rows * n * 4 : 0);
  return stored + computed + n * 64;
}

void MatrixRadiosity::applyMaterials(std::span<const Material> materials) {
  PENUMBRA_CHECK(system.has_value());
  surface.applyMaterials(materials);
  for (size_t k = 0; k < size(); ++k) {
    const uint32_t b = surface.hierarchy.elementBegin(clusters[k]);
    const uint32_t e = surface.hierarchy.elementEnd(clusters[k]);
    // The cluster reflects what its elements reflect: the area-weighted mean of their
    // reflectances (textures and cut-outs vary it within one material), and of the lights'
    // direct irradiance each reflects.
    glm::dvec3 emitted(0.0), reflected(0.0), rho_area(0.0);
    double area = 0.0;
    for (uint32_t i = b; i < e; ++i) {
      const double a = surface.atlas.element_area[i];
      emitted += surface.emission[i] * a;
      rho_area += surface.reflectance[i] * a;
      area += a;
      if (!direct.empty()) reflected += surface.reflectance[i] * direct[i] * a;
      if (!outside.empty()) reflected += surface.reflectance[i] * outside[i] * a;
    }
    system->reflectance[k] = glm::vec3(area > 0.0 ? rho_area / area : surface.reflectance[b]);
    system->emission[k] = glm::vec3((emitted + reflected) / cluster_area[k]);
  }
}

uint64_t MatrixRadiosity::setLights(std::span<const Light> lights) {
  uint64_t rays = 0;
  direct.clear();
  if (!lights.empty()) direct = surface.lightIrradiance(lights, light_visibility, &rays);
  return rays;
}

bool MatrixRadiosity::emittedByMaterial(size_t k) const {
  const uint32_t b = surface.hierarchy.elementBegin(clusters[k]);
  const uint32_t e = surface.hierarchy.elementEnd(clusters[k]);
  for (uint32_t i = b; i < e; ++i) {
    if (surface.emission[i] != glm::dvec3(0.0)) return true;
  }
  return false;
}

SolveStats MatrixRadiosity::solve(const SolveOptions& options,
                                  const std::function<void(int, double)>& after_iteration) {
  PENUMBRA_CHECK(system.has_value());
  radiosity.resize(size(), glm::vec3(0.0f));
  return solveRadiosity(*system, radiosity, options, after_iteration, comm);
}

std::vector<glm::dvec3> MatrixRadiosity::elementRadiosity(bool interpolate) const {
  PENUMBRA_CHECK(system.has_value() && radiosity.size() == size());
  // The rows held here (all on one process); the other ranks' rows are added below.
  std::vector<glm::dvec3> gathered = gatherIrradiance(*system, radiosity);
  // The emitters' part is gathered at each element instead (G_e).
  const size_t ns = emitters.size();
  const size_t n_el = surface.elementCount();
  std::vector<glm::dvec3> g;
  if (ns > 0) {
    g.assign(n_el, glm::dvec3(0.0));
    parallelRange(size(), 16, [&](size_t b, size_t end) {
      for (size_t k = b; k < end; ++k) {
        if (k >= system->rowBegin() && k < system->rowEnd()) {
          for (uint32_t j : emitters) {
            gathered[k] -= double(system->formFactor(uint32_t(k), j)) * glm::dvec3(radiosity[j]);
          }
        }
        for (uint32_t e = surface.hierarchy.elementBegin(clusters[k]);
             e < surface.hierarchy.elementEnd(clusters[k]); ++e) {
          for (size_t s = 0; s < ns; ++s) {
            g[e] += double(element_ff[e * ns + s]) * glm::dvec3(radiosity[emitters[s]]);
          }
        }
      }
    });
  }
  if (comm && comm->distributed()) {
    const std::span<const glm::dvec3> held(gathered.data() + system->rowBegin(),
                                           system->rowEnd() - system->rowBegin());
    gathered = allgatherValues<glm::dvec3>(*comm, held);
  }
  std::vector<glm::dvec3> h;
  if (interpolate) {
    if (near_hit.empty()) {
      h = surface.hierarchy.interpolate(surface.atlas, clusters, gathered);
    } else {
      // The near field of the file comment: per element, the mean over its rays of the
      // radiosity of the clusters they landed on (emitting ones are G_e's), and its share of
      // free rays; per cluster, their area-weighted means.
      std::vector<uint8_t> emitting(size(), 0);
      for (uint32_t j : emitters) emitting[j] = 1;
      std::vector<glm::dvec3> near(n_el, glm::dvec3(0.0));
      std::vector<double> free(n_el, 1.0);
      std::vector<glm::dvec3> near_mean(size(), glm::dvec3(0.0)), free_mean(size());
      parallelRange(size(), 16, [&](size_t b, size_t end) {
        for (size_t k = b; k < end; ++k) {
          double area = 0.0, open = 0.0;
          for (uint32_t e = surface.hierarchy.elementBegin(clusters[k]);
               e < surface.hierarchy.elementEnd(clusters[k]); ++e) {
            int open_rays = 0;
            glm::dvec3 sum(0.0);
            for (int r = 0; r < kSubClusterRays; ++r) {
              const int32_t hit = near_hit[size_t(e) * kSubClusterRays + size_t(r)];
              if (hit == kFree) {
                ++open_rays;
              } else if (hit >= 0 && !emitting[element_cluster[size_t(hit)]]) {
                sum += glm::dvec3(radiosity[element_cluster[size_t(hit)]]);
              }
            }
            near[e] = sum / double(kSubClusterRays);
            free[e] = double(open_rays) / kSubClusterRays;
            const double a = surface.atlas.element_area[e];
            near_mean[k] += near[e] * a;
            open += free[e] * a;
            area += a;
          }
          if (area > 0.0) near_mean[k] /= area;
          free_mean[k] = glm::dvec3(area > 0.0 ? open / area : 1.0);
        }
      });
      for (size_t k = 0; k < size(); ++k) gathered[k] -= near_mean[k];
      h = surface.hierarchy.interpolate(surface.atlas, clusters, gathered);
      const std::vector<glm::dvec3> v =
          surface.hierarchy.interpolate(surface.atlas, clusters, free_mean);
      for (size_t e = 0; e < n_el; ++e) {
        const glm::dvec3 far = v[e].x > 0.0 ? h[e] * (free[e] / v[e].x) : glm::dvec3(0.0);
        h[e] = glm::max(far, glm::dvec3(0.0)) + near[e];
      }
    }
  } else {
    h.resize(n_el);
    for (size_t k = 0; k < size(); ++k) {
      for (uint32_t e = surface.hierarchy.elementBegin(clusters[k]);
           e < surface.hierarchy.elementEnd(clusters[k]); ++e) {
        h[e] = gathered[k];
      }
    }
  }
  parallelRange(n_el, 1024, [&](size_t b, size_t end) {
    for (size_t e = b; e < end; ++e) {
      const glm::dvec3 in = h[e] + (direct.empty() ? glm::dvec3(0.0) : direct[e]) +
                            (outside.empty() ? glm::dvec3(0.0) : outside[e]) +
                            (g.empty() ? glm::dvec3(0.0) : g[e]);
      h[e] = surface.emission[e] + surface.reflectance[e] * in;
    }
  });
  return h;
}

Image MatrixRadiosity::radianceImage(bool interpolate) const {
  return surface.radianceImage(elementRadiosity(interpolate));
}

Expected<MatrixRadiosity> buildMatrixRadiosity(const Scene& scene,
                                               const MatrixRadiosityOptions& options,
                                               const std::function<void(size_t, size_t)>& on_row,
                                               Communicator* comm) {
  const int ranks = comm ? comm->size() : 1;
  PENUMBRA_TRY(checkMatrixRadiosity(scene, options, ranks));
  Expected<ChartAtlasOptions> ao = lightmapAtlasOptions(scene, lightmapFor(options));
  if (!ao) return ao.error();

  MatrixRadiosity mr;
  Expected<RadiositySurface> surface = RadiositySurface::build(scene, *ao, options.shading_normals);
  if (!surface) return surface.error();
  mr.surface = std::move(*surface);
  mr.clusters = mr.surface.hierarchy.cut(options.elements);
  const uint64_t n = mr.clusters.size();
  mr.cluster_area.resize(n);
  for (size_t k = 0; k < n; ++k) {
    mr.cluster_area[k] =
        mr.surface.hierarchy.level(mr.clusters[k].level).area[mr.clusters[k].index];
  }
  PENUMBRA_TRY(checkSystemMemory(n, options.precision, ranks, n));
  mr.comm = comm && comm->distributed() ? comm : nullptr;
  // Everything transport takes, timed together: the pieces, the clusters' form factors, the
  // lights' shadow rays and the emitters' per-element form factors.
  const Timer transport_timer;
  const ElementPieces pieces = ElementPieces::build(mr.surface);
  Expected<FormFactorMatrix> f = computeFormFactors(
      mr.surface, mr.clusters, options.form_factors, &mr.form_factor_stats,
      [&](size_t done) {
        if (on_row) on_row(done, size_t(n));
      },
      &pieces, mr.comm);
  if (!f) return f.error();
  mr.system.emplace(std::move(*f), options.precision);
  mr.light_visibility = options.form_factors.visibility;
  mr.form_factor_stats.rays += mr.setLights(scene.lights);
  if (const OutsideLight sky(scene); sky.active()) {
    // The same on every rank (each element has its own stream).
    mr.outside = sky.irradiance(mr.surface, &mr.form_factor_stats.rays);
    mr.outside_power = arrivingPower(mr.surface, mr.outside);
  }
  mr.applyMaterials(scene.materials);
  {
    // The emitting clusters, if they are few enough.
    for (uint32_t k = 0; k < n; ++k) {
      if (mr.emittedByMaterial(k)) mr.emitters.push_back(k);
    }
    double emitting_area = 0.0;
    for (uint32_t k : mr.emitters) emitting_area += mr.cluster_area[k];
    if (uint64_t(mr.emitters.size()) * mr.surface.elementCount() > kElementGatherBudget ||
        emitting_area > kElementGatherArea * mr.surface.total_area) {
      mr.emitters.clear();
    }
    if (!mr.emitters.empty()) {
      Expected<std::vector<float>> ff =
          computeElementFormFactors(mr.surface, mr.clusters, mr.emitters, options.form_factors,
                                    &mr.form_factor_stats, &pieces, mr.comm);
      if (!ff) return ff.error();
      mr.element_ff = std::move(*ff);
    }
  }
  if (options.form_factors.visibility) {
    traceSubClusterRays(mr.surface, mr.clusters, options.form_factors.seed, mr.near_hit,
                        &mr.form_factor_stats.rays);
    mr.element_cluster.resize(mr.surface.elementCount());
    for (uint32_t k = 0; k < n; ++k) {
      for (uint32_t e = mr.surface.hierarchy.elementBegin(mr.clusters[k]);
           e < mr.surface.hierarchy.elementEnd(mr.clusters[k]); ++e) {
        mr.element_cluster[e] = k;
      }
    }
  }
  mr.form_factor_stats.seconds = transport_timer.seconds();
  mr.radiosity.assign(n, glm::vec3(0.0f));
  return mr;
}

}  // namespace penumbra
