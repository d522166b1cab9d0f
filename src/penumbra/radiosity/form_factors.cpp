#include "penumbra/radiosity/form_factors.h"

#include "penumbra/core/memory.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/core/timer.h"
#include "penumbra/kernels/form_factor.h"
#include "penumbra/kernels/sampling.h"
#include "penumbra/raytrace/ray_engine.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>

namespace penumbra {

double FormFactorMatrix::rowSum(uint32_t i) const {
  double s = 0.0;
  for (uint32_t j = 0; j < n; ++j) s += (*this)(i, j);
  return s;
}

namespace {

// Point with stratum (sx, sy) of a g x g grid on element e, jittered by (u1, u2).
glm::dvec3 stratifiedPoint(const Elements& el, uint32_t e, int sx, int sy, int g, float u1,
                           float u2) {
  const glm::vec2 b =
      sampleTriangleBarycentrics((float(sx) + u1) / float(g), (float(sy) + u2) / float(g));
  const glm::uvec3 t = el.triangles[e];
  const glm::dvec3 p0 = el.positions[t.x], p1 = el.positions[t.y], p2 = el.positions[t.z];
  return (1.0 - double(b.x) - double(b.y)) * p0 + double(b.x) * p1 + double(b.y) * p2;
}

// A shadow ray between points x and y of two elements, each lifted off its surface.
Ray visibilityRay(const glm::dvec3& x, const glm::dvec3& nx, const glm::dvec3& y,
                  const glm::dvec3& ny, double lift) {
  const glm::dvec3 from = x + nx * lift, to = y + ny * lift;
  return Ray{glm::vec3(from), 1e-4f, glm::vec3(to - from), 1.0f - 1e-4f};
}

// Whether every corner of element `e` lies on or behind the plane (point c, normal n).
bool behind(const Elements& el, uint32_t e, const glm::dvec3& c, const glm::dvec3& n) {
  for (int k = 0; k < 3; ++k) {
    if (glm::dot(n, glm::dvec3(el.positions[el.triangles[e][k]]) - c) > 0.0) return false;
  }
  return true;
}

}  // namespace

Expected<FormFactorMatrix> computeFormFactors(const Elements& el, const FormFactorOptions& options,
                                              FormFactorStats* stats,
                                              const std::function<void(size_t)>& on_row) {
  const Timer timer;
  const uint64_t n = el.size();
  PENUMBRA_TRY(
      checkMemory(formFactorBytes(n), fmt::format("the {} x {} form-factor matrix", n, n)));
  if (options.samples < 1) return inputError("", "form factors", "samples must be at least 1");
  FormFactorMatrix m;
  m.n = uint32_t(n);
  m.f.assign(n * n, 0.0f);

  const RayEngine engine = RayEngine::build(el.scene.positions, el.scene.triangles);
  const Bounds3 box = engine.bounds();
  // Ray end points are lifted off their surfaces by this much (relative to the scene).
  const double lift = 1e-5 * double(glm::length(box.hi - box.lo));
  const int g = int(std::ceil(std::sqrt(double(options.samples)) - 1e-9));
  const int samples = g * g;
  // Element sizes: the radius of the disc of the element's area.
  std::vector<double> radius(n);
  for (size_t e = 0; e < n; ++e) radius[e] = std::sqrt(double(el.area[e]) / 3.14159265358979);
  constexpr double kNear = 4.0;
  std::atomic<uint64_t> rays{0};
  std::atomic<size_t> rows_done{0};

  parallelRange(n, 1, [&](size_t begin, size_t end) {
    std::vector<glm::dvec3> xs(static_cast<size_t>(samples));
    uint64_t local_rays = 0;
    for (size_t i = begin; i < end; ++i) {
      // The row's receiver points, from the row's own stream (thread-count independent).
      Rng row_rng(mixBits(options.seed), i);
      for (int s = 0; s < samples; ++s) {
        xs[size_t(s)] =
            stratifiedPoint(el, uint32_t(i), s % g, s / g, g, row_rng.uniform(), row_rng.uniform());
      }
      const glm::dvec3 ni = el.normal[i], ci = el.centroid[i];
      float* row = &m.f[i * n];
      for (size_t j = 0; j < n; ++j) {
        if (j == i || el.source[j] == el.source[i]) continue;  // coplanar: F = 0
        const glm::dvec3 nj = el.normal[j], cj = el.centroid[j];
        // j wholly below i's horizon, or i wholly behind j's front face: nothing to exchange.
        if (behind(el, uint32_t(j), ci, ni) || behind(el, uint32_t(i), cj, nj)) continue;
        const glm::uvec3 tj = el.triangles[j];
        const glm::dvec3 a = el.positions[tj.x], b = el.positions[tj.y], c = el.positions[tj.z];
        Rng pair_rng(mixBits(options.seed ^ 0x9e3779b97f4a7c15ull), i * n + j);
        // Visibility: near pairs (centroids closer than kNear times the elements' sizes) trace
        // one ray per sample point; far pairs, where visibility changes slowly over i, one ray
        // per 2 x 2 block of strata, whose answer serves the block's points. The form factors
        // themselves are evaluated at every point of the row's one point set, so that in an
        // unoccluded closed scene each row still sums to 1.
        const double reach = radius[i] + radius[j];
        const bool near = options.estimator == FormFactorEstimator::kMonteCarlo ||
                          glm::dot(cj - ci, cj - ci) < kNear * kNear * reach * reach;
        int8_t block_visible[4] = {-1, -1, -1, -1};  // -1: not traced yet
        double sum = 0.0;
        for (int s = 0; s < samples; ++s) {
          const glm::dvec3& x = xs[size_t(s)];
          const int sx = s % g, sy = s / g;
          double value;
          if (options.estimator == FormFactorEstimator::kPointPolygon) {
            if (glm::dot(nj, x - cj) <= 0.0) continue;  // x sees j's back
            value = pointToTriangleFormFactor(x, ni, a, b, c);
          } else {
            const glm::dvec3 y =
                stratifiedPoint(el, uint32_t(j), sx, sy, g, pair_rng.uniform(), pair_rng.uniform());
            value = differentialFormFactorKernel(x, ni, y, nj) * double(el.area[j]);
            if (value > 0.0 && options.visibility) {
              ++local_rays;
              if (engine.occluded(visibilityRay(x, ni, y, nj, lift))) continue;
            }
            sum += value;
            continue;
          }
          if (value <= 0.0) continue;
          if (options.visibility) {
            if (near) {
              const glm::dvec3 y = stratifiedPoint(el, uint32_t(j), sx, sy, g, pair_rng.uniform(),
                                                   pair_rng.uniform());
              ++local_rays;
              if (engine.occluded(visibilityRay(x, ni, y, nj, lift))) continue;
            } else {
              const int bg = std::min(g, 2);
              const int bx = sx * bg / g, by = sy * bg / g, block = by * bg + bx;
              if (block_visible[block] < 0) {
                const glm::dvec3 y = stratifiedPoint(el, uint32_t(j), bx, by, bg,
                                                     pair_rng.uniform(), pair_rng.uniform());
                ++local_rays;
                block_visible[block] = engine.occluded(visibilityRay(x, ni, y, nj, lift)) ? 0 : 1;
              }
              if (block_visible[block] == 0) continue;
            }
          }
          sum += value;
        }
        row[j] = float(sum / double(samples));
      }
      const size_t done = rows_done.fetch_add(1) + 1;
      if (on_row) on_row(done);
    }
    rays += local_rays;
  });
  if (stats) {
    stats->seconds = timer.seconds();
    stats->pairs = n * n - n;
    stats->rays = rays.load();
  }
  return m;
}

}  // namespace penumbra
