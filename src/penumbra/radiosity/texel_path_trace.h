// The path-traced lightmap: every texel of a radiosity lightmap atlas gets its radiosity by
// unbiased path tracing, the reference every radiosity bake is measured against texel by texel
// (bake --method pathtrace), as production bakers (Unity's progressive lightmapper, Bakery,
// Blender's bake) compute theirs.
//
// For element e (an atlas texel) with footprint A_e (its pieces: the chart's faces clipped to the
// texel, on the surface), the radiosity is the footprint's mean
//   B_e = (1 / A_e) * integral over A_e of B(x) dA,   B(x) = pi L_o(x)
// for the diffuse surface, L_o(x) = L_e(x) + (rho(x) / pi) * E(x) the radiance leaving x. Each
// sample takes x uniformly by area over the footprint and asks the path tracer
// (raytrace/path_tracer.h) for the radiance leaving x towards a point just above it: its own
// estimator, with next-event estimation at x itself (area emitters, point, spot and directional
// lights, luminaires), textures at x and Russian roulette, so the bake is exactly as unbiased as
// the renders. A point that falls in a cut-out's hole is drawn again: B(x) is 0 there, so the
// texel's B is the coverage (RadiositySurface::coverage) times the mean over the points drawn on
// the surface, as the radiosity methods' B is per texel area (their reflectance and emission
// are coverage-weighted means), and the irradiance B / rho an engine takes is the same in both.
//
// Stopping rule: every texel takes `min_samples`; then each continues in batches until the
// standard error of its radiosity estimate is at most `target_error` times the larger of its
// own mean and a floor (a tenth of the lightmap's mean radiosity after the first round, so
// that texels in shadow do not run to the cap for a relative error of nothing), or it reaches
// `max_samples`. The error is trusted only once 16 of a texel's samples carried light: a texel
// lit by rare paths alone would otherwise stop black after 64 zeros (whose standard error is 0);
// a texel that none of 1,024 samples lit is taken as dark.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/radiosity/radiosity_surface.h"
#include "penumbra/scene/scene.h"

#include <glm/vec3.hpp>

#include <cstdint>
#include <functional>
#include <vector>

namespace penumbra {

struct TexelPathTraceOptions {
  int min_samples = 64;
  int max_samples = 4096;
  double target_error = 0.02;  // relative standard error of each texel's irradiance
  int max_depth = 0;           // as the path tracer's (0: Russian roulette ends paths)
  uint64_t seed = 0;
};

struct TexelPathTraceStats {
  uint64_t samples = 0;  // over all texels
  uint64_t rays = 0;
  double seconds = 0.0;
  double mean_samples = 0.0;
  uint64_t texels_at_cap = 0;         // stopped by max_samples, not by the error
  double worst_relative_error = 0.0;  // the largest standard error / max(mean, floor)
};

// Radiosity B (W m^-2) per element of `surface`, built over `scene` (which must have passed
// validateScene). `progress(done, total)` counts texels, from any thread. Refuses options out of
// range.
Expected<std::vector<glm::dvec3>> pathTraceTexels(
    const Scene& scene, const RadiositySurface& surface, const TexelPathTraceOptions& options,
    TexelPathTraceStats* stats = nullptr, const std::function<void(size_t, size_t)>& progress = {});

}  // namespace penumbra
