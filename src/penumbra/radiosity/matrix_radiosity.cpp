#include "penumbra/radiosity/matrix_radiosity.h"

#include "penumbra/core/check.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"

#include <fmt/format.h>

#include <algorithm>
#include <numbers>

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
    glm::dvec3 emitted(0.0), lit(0.0);
    for (uint32_t i = b; i < e; ++i) {
      const double a = surface.atlas.element_area[i];
      emitted += surface.emission[i] * a;
      if (!direct.empty()) lit += direct[i] * a;
    }
    // A cluster lies in one chart, so it has one material.
    const glm::dvec3 rho = surface.reflectance[b];
    system->reflectance[k] = glm::vec3(rho);
    system->emission[k] = glm::vec3((emitted + rho * lit) / cluster_area[k]);
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
    h = surface.hierarchy.interpolate(surface.atlas, clusters, gathered);
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
  mr.form_factor_stats.seconds = transport_timer.seconds();
  mr.radiosity.assign(n, glm::vec3(0.0f));
  return mr;
}

}  // namespace penumbra
