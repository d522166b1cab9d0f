#include "penumbra/radiosity/texel_path_trace.h"

#include "penumbra/core/color.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/core/timer.h"
#include "penumbra/radiosity/texel_footprint.h"
#include "penumbra/raytrace/path_tracer.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <numbers>

namespace penumbra {

namespace {

// One texel's running sums: the radiosity's colour and its luminance's first two moments.
struct TexelSums {
  glm::dvec3 radiosity{0.0};
  double sum = 0.0, sum_sq = 0.0;
  uint32_t samples = 0;
  uint32_t lit = 0;    // samples that carried light
  uint64_t drawn = 0;  // attempts, holes included (where the texel's random stream stands)
  bool done = false;

  double mean() const { return samples ? sum / samples : 0.0; }
  // Standard error of the mean luminance.
  double standardError() const {
    if (samples < 2) return std::numeric_limits<double>::infinity();
    const double m = mean();
    const double variance = std::max(sum_sq / samples - m * m, 0.0) * samples / (samples - 1);
    return std::sqrt(variance / samples);
  }
};

class TexelTracer {
 public:
  TexelTracer(const Scene& scene, const RadiositySurface& surface,
              const TexelPathTraceOptions& options)
      : scene_(scene),
        surface_(surface),
        tracer_(scene),
        options_(options),
        lift_(footprintLift(surface)) {
    settings_.max_depth = options.max_depth;
    settings_.seed = options.seed;
    settings_.low_discrepancy = false;
  }

  // `count` more samples of element e, continuing its own random stream (so the result does not
  // depend on the thread count or the batching).
  uint64_t sample(size_t e, int count, TexelSums& sums) const {
    const TexelFootprint f = texelFootprint(surface_, e);
    const glm::dvec3 anchor = surface_.atlas.element_position[e];
    Rng rng(mixBits(options_.seed), e);
    rng.advance(uint64_t(sums.drawn) * kDrawsPerSample);
    uint64_t rays = 0;
    // A point on a cut-out's hole is not on the surface: it is drawn again, a bounded number of
    // times (a texel that is all hole keeps its emission alone).
    for (int k = 0, attempts = 0; k < count && attempts < 8 * count + 64; ++attempts) {
      // Each attempt draws exactly kDrawsPerSample numbers from `rng` (the path from its own).
      const float u0 = rng.uniform(), u1 = rng.uniform(), u2 = rng.uniform();
      const uint64_t path_stream = rng.nextU32() | uint64_t(rng.nextU32()) << 32;
      ++sums.drawn;
      const glm::dvec3 x = f.sample(u0, u1, u2);
      // Only the part of the footprint the texel stands for: what its anchor sees (a point under
      // a box standing on the chart, or past a wall, is drawn again).
      if (!footprintPointsSeeEachOther(surface_, anchor, x, f.normal, lift_)) continue;
      // Looking down at x from just above it: the path tracer's radiance leaving x towards the
      // origin is L_o(x) = L_e + (rho / pi) E(x) for the diffuse surface, with next-event
      // estimation at x itself (area emitters and every light), so B(x) = pi L_o(x).
      const double h = 4.0 * surface_.lift;
      const Ray down{glm::vec3(x + f.normal * h), 0.0f, glm::vec3(-f.normal), float(2.0 * h)};
      const Hit hit = surface_.engine.intersect(down);
      ++rays;
      if (!hit.hit() || std::abs(double(hit.t) - h) > 0.5 * h) continue;  // a hole, or a sliver
      Rng path_rng(mixBits(options_.seed ^ 0x7e8e1), path_stream);
      const glm::dvec3 b =
          std::numbers::pi * glm::dvec3(tracer_.radiance(down, path_rng, settings_, rays));
      // The texel keeps the reflected part, rho E, of each sample: the path tracer's radiance
      // less the emission at x (the first hit's, texture and all). The texel's emission is added
      // back exactly at the end, so neither the lightmap nor the stopping rule carries the
      // emission texture's variation over the footprint, and on an emitter the emission does
      // not hide the noise of the little light it reflects (the irradiance E an engine takes,
      // methods/bake_output.h, divides that part by rho).
      const glm::dvec3 reflected = b - std::numbers::pi * emittedAt(e, hit);
      const double y = double(luminance(glm::vec3(reflected)));
      sums.radiosity += reflected;
      sums.sum += y;
      sums.sum_sq += y * y;
      ++sums.samples;
      if (y > 0.0) ++sums.lit;
      ++k;
    }
    return rays;
  }

 private:
  // The radiance emitted at a hit on element e's side (W m^-2 sr^-1): the front of an emissive
  // material, its emission texture included.
  glm::dvec3 emittedAt(size_t e, const Hit& hit) const {
    if (surface_.atlas.faces[surface_.atlas.element_face[e]].back) return glm::dvec3(0.0);
    const uint32_t tri = uint32_t(hit.triangle);
    if (scene_.materials[surface_.flat.material_ids[tri]].unlit) return glm::dvec3(0.0);
    if (surface_.textures) return glm::dvec3(surface_.textures->emission(tri, {hit.u, hit.v}));
    return glm::dvec3(scene_.materials[surface_.flat.material_ids[tri]].emission);
  }

  static constexpr uint64_t kDrawsPerSample = 5;
  const Scene& scene_;
  const RadiositySurface& surface_;
  PathTracer tracer_;
  PathTracerSettings settings_;
  TexelPathTraceOptions options_;
  double lift_;  // footprint points are lifted by this for the anchor's visibility
};

constexpr uint64_t kHoleDraws = 16;
constexpr uint32_t kMinLit = 16;
constexpr uint32_t kUnlitSamples = 1024;

Status checkOptions(const TexelPathTraceOptions& o) {
  if (o.min_samples < 1 || o.max_samples < o.min_samples || o.max_samples > (1 << 20)) {
    return inputError("", "texel path tracing",
                      fmt::format("samples per texel: need 1 <= min ({}) <= max ({}) <= 2^20",
                                  o.min_samples, o.max_samples));
  }
  if (!(o.target_error > 0.0 && o.target_error < 1.0)) {
    return inputError("", "texel path tracing",
                      fmt::format("target error {} is outside (0, 1)", o.target_error));
  }
  return {};
}

}  // namespace

Expected<std::vector<glm::dvec3>> pathTraceTexels(
    const Scene& scene, const RadiositySurface& surface, const TexelPathTraceOptions& options,
    TexelPathTraceStats* stats, const std::function<void(size_t, size_t)>& progress) {
  PENUMBRA_TRY(checkOptions(options));
  const Timer timer;
  const size_t n = surface.elementCount();
  const TexelTracer tracer(scene, surface, options);
  std::vector<TexelSums> sums(n);
  std::atomic<uint64_t> rays{0};
  std::atomic<size_t> finished{0};
  // A round: every texel not yet done takes `batch` more samples.
  const auto round = [&](int batch, const std::function<bool(const TexelSums&)>& stop) {
    parallelRange(n, 64, [&](size_t begin, size_t end) {
      uint64_t traced = 0;
      for (size_t e = begin; e < end; ++e) {
        if (sums[e].done) continue;
        if (stoppedMidStep()) break;
        const int left = options.max_samples - int(sums[e].samples);
        const uint32_t before = sums[e].samples;
        traced += tracer.sample(e, std::min(batch, left), sums[e]);
        // A texel that is (almost) all cut-out hole: once it has drawn kHoleDraws points per
        // sample it may take without landing on the surface, it keeps what it has (its
        // emission when nothing). A partly covered one continues like any other, so that its
        // few points on the surface are not a handful of samples.
        const bool hole = sums[e].samples == before &&
                          sums[e].drawn >= kHoleDraws * uint64_t(options.max_samples);
        if (hole || stop(sums[e])) {
          sums[e].done = true;
          const size_t done = ++finished;
          if (progress) progress(done, n);
        }
      }
      rays += traced;
    });
    throwIfStoppedMidStep();
  };
  // The standard error is trusted only once a texel has seen light kMinLit times: 64 samples of
  // exactly zero have a standard error of zero, and a texel lit only by rare paths (through a
  // cut-out's lattice) would stop black. A texel that no sample of kUnlitSamples lit is taken
  // as dark (light reaching it in under 3 of that many paths, at 95% confidence).
  const auto unlit = [&](const TexelSums& s) {
    return s.lit == 0 && s.samples >= std::min(kUnlitSamples, uint32_t(options.max_samples));
  };
  round(options.min_samples, [&](const TexelSums& s) {
    return s.samples >= uint32_t(options.max_samples) || unlit(s) ||
           (s.lit >= kMinLit && s.standardError() <= options.target_error * s.mean());
  });
  // The floor: a tenth of the lightmap's mean radiosity (area-weighted).
  double weighted = 0.0, area = 0.0;
  for (size_t e = 0; e < n; ++e) {
    weighted += sums[e].mean() * surface.atlas.element_area[e];
    area += surface.atlas.element_area[e];
  }
  const double floor = area > 0.0 ? 0.1 * weighted / area : 0.0;
  const auto converged = [&](const TexelSums& s) {
    return s.samples >= uint32_t(options.max_samples) || unlit(s) ||
           (s.lit >= kMinLit &&
            s.standardError() <= options.target_error * std::max(s.mean(), floor));
  };
  for (size_t e = 0; e < n; ++e) {
    if (!sums[e].done && converged(sums[e])) {
      sums[e].done = true;
      const size_t done = ++finished;
      if (progress) progress(done, n);
    }
  }
  for (int batch = options.min_samples; finished.load() < n;) {
    batch = std::min(batch * 2, options.max_samples);  // the rounds double the samples taken
    round(batch, converged);
  }

  std::vector<glm::dvec3> b(n);
  TexelPathTraceStats st;
  for (size_t e = 0; e < n; ++e) {
    const TexelSums& s = sums[e];
    // The samples are points of the surface (holes of cut-outs drawn again), so their mean is
    // the radiosity per area of surface; an element's B is per area of its footprint, as its
    // reflectance and emission are (coverage-weighted means): the mean times the coverage.
    b[e] =
        surface.emission[e] +
        (s.samples > 0 ? surface.coverageOf(e) * s.radiosity / double(s.samples) : glm::dvec3(0.0));
    st.samples += s.samples;
    if (s.samples >= uint32_t(options.max_samples) &&
        s.standardError() > options.target_error * std::max(s.mean(), floor)) {
      ++st.texels_at_cap;
    }
    const double denominator = std::max(s.mean(), floor);
    if (denominator > 0.0) {
      st.worst_relative_error = std::max(st.worst_relative_error, s.standardError() / denominator);
    }
  }
  st.rays = rays.load();
  st.seconds = timer.seconds();
  st.mean_samples = n ? double(st.samples) / double(n) : 0.0;
  if (stats) *stats = st;
  return b;
}

}  // namespace penumbra
