#include "penumbra/radiosity/matrix_radiosity.h"

#include "penumbra/core/check.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/parallel.h"
#include "penumbra/kernels/sampling.h"
#include "penumbra/radiosity/lights.h"
#include "penumbra/raytrace/ray_engine.h"

#include <glm/geometric.hpp>

#include <cmath>
#include <limits>

#include <fmt/format.h>

namespace penumbra {

uint64_t matrixRadiosityBytes(uint64_t n, MatrixPrecision precision) {
  const uint64_t stored = n * n * (precision == MatrixPrecision::kFp32 ? 4 : 2);
  const uint64_t computed = precision == MatrixPrecision::kFp32 ? 0 : n * n * 4;
  return stored + computed + elementBytes(n) + n * 64;
}

void MatrixRadiosity::applyMaterials(std::span<const Material> materials) {
  PENUMBRA_CHECK(system.has_value());
  for (size_t e = 0; e < elements.size(); ++e) {
    const Material& m = materials[elements.material[e]];
    system->reflectance[e] = m.reflectance;
    system->emission[e] = m.emission * kPi;
    if (!direct.empty()) system->emission[e] += m.reflectance * direct[e];
  }
}

SolveStats MatrixRadiosity::solve(const SolveOptions& options,
                                  const std::function<void(int, double)>& after_iteration) {
  PENUMBRA_CHECK(system.has_value());
  radiosity.resize(elements.size(), glm::vec3(0.0f));
  return solveRadiosity(*system, radiosity, options, after_iteration);
}

std::vector<glm::vec3> MatrixRadiosity::cornerRadiance() const {
  std::vector<glm::vec3> radiance(radiosity.size());
  for (size_t e = 0; e < radiosity.size(); ++e) radiance[e] = radiosity[e] * kInvPi;
  return elements.cornerAverage(radiance);
}

Expected<MatrixRadiosity> buildMatrixRadiosity(const Scene& scene,
                                               const MatrixRadiosityOptions& options,
                                               const std::function<void(size_t, size_t)>& on_row) {
  MatrixRadiosity mr;
  Expected<Elements> elements = meshElements(scene, options.meshing);
  if (!elements) return elements.error();
  mr.elements = std::move(*elements);
  const uint64_t n = mr.elements.size();
  PENUMBRA_TRY(
      checkMemory(matrixRadiosityBytes(n, options.precision),
                  fmt::format("matrix radiosity with {} elements ({} form factors)", n, n * n)));
  Expected<FormFactorMatrix> f = computeFormFactors(mr.elements, options.form_factors,
                                                    &mr.form_factor_stats, [&](size_t done) {
                                                      if (on_row) on_row(done, size_t(n));
                                                    });
  if (!f) return f.error();
  mr.system.emplace(std::move(*f), options.precision);
  if (!scene.lights.empty()) {
    // The direct term: each light's irradiance at the element's centroid on its front face,
    // unless a shadow ray finds the light hidden.
    const RayEngine engine =
        RayEngine::build(mr.elements.scene.positions, mr.elements.scene.triangles);
    const Bounds3 box = engine.bounds();
    const double lift = 1e-5 * double(glm::length(box.hi - box.lo));
    mr.direct.assign(n, glm::vec3(0.0f));
    parallelRange(n, 256, [&](size_t b, size_t e_end) {
      for (size_t e = b; e < e_end; ++e) {
        const glm::dvec3 p(mr.elements.centroid[e]), nrm(mr.elements.normal[e]);
        glm::dvec3 sum(0.0);
        for (const Light& light : scene.lights) {
          const LightSample s = sampleLight(light, p, nrm, nrm);
          if (s.irradiance == glm::dvec3(0.0)) continue;
          const glm::dvec3 from = p + nrm * lift;
          Ray ray{glm::vec3(from), 1e-4f, glm::vec3(s.direction),
                  std::numeric_limits<float>::max()};
          if (std::isfinite(s.distance)) {
            ray.dir = glm::vec3(s.direction * s.distance);
            ray.tmax = 1.0f - 1e-4f;
          }
          if (!engine.occluded(ray)) sum += s.irradiance;
        }
        mr.direct[e] = glm::vec3(sum);
      }
    });
  }
  mr.applyMaterials(scene.materials);
  mr.radiosity.assign(n, glm::vec3(0.0f));
  return mr;
}

}  // namespace penumbra
