// Photometric output for lighting design: illuminance in lux on calculation points (a work plane,
// the points a camera sees) from any method's solution, with the figures lighting designers
// report (EN 12464-1): average, minimum, maximum and uniformity U0 = E_min / E_avg, direct and
// total separately; CSV tables and false-colour pictures with a legend in lux.
//
// Lux are 683 lm/W (Wallner eq. 12, the luminaires' own conversion, scene/luminaire.h) times the
// irradiance's luminance (Rec. 709 weights), so a luminaire gives the lux its file promises.
//
// The illuminance at a point x with normal n is the exact direct part plus a gather, whatever
// method made the solution:
//   E(x) = sum over delta lights of E_light V (a shadow ray each, as the radiosity methods shoot)
//        + sum over area emitters of pi L F V (Lambert's closed form times the visible share,
//          render/direct_emitters.h)
//        + pi / N sum over N stratified cosine-distributed directions of (L(x, w) - L_e),
// where L is the method's radiance along the ray (the lightmap of a radiosity solution, which
// holds emitters' emission and all interreflection, or the path tracer's estimate) and L_e the
// emission of the emitter the ray hits, which the closed form has counted. The direct part is the
// first two sums (plus, for emitters the closed form does not take, textured ones, their
// emission found by the rays).
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/core/rng.h"
#include "penumbra/io/calculation_objects.h"
#include "penumbra/kernels/ray.h"
#include "penumbra/raytrace/ray_engine.h"
#include "penumbra/render/glare.h"
#include "penumbra/scene/camera.h"
#include "penumbra/scene/scene.h"

#include <glm/vec3.hpp>

#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace penumbra {

// Lux of an irradiance (W m^-2 per channel).
double luxOf(const glm::dvec3& irradiance);

// The figures of a set of illuminance values, lux: the average (weighted by `areas` when given),
// minimum, maximum, and the uniformities U0 = minimum / average and U1 = minimum / maximum (0
// when the divisor is 0).
struct IlluminanceStats {
  double average = 0.0, minimum = 0.0, maximum = 0.0, uniformity = 0.0, uniformity_u1 = 0.0;
};
IlluminanceStats illuminanceStats(std::span<const double> lux, std::span<const double> areas = {});

// Radiance (W m^-2 sr^-1) arriving along `ray` whose closest hit is `hit` (a miss: triangle -1),
// from the method's solution; `rng` for estimators that need random numbers.
using IncidentRadiance = std::function<glm::vec3(const Ray& ray, const Hit& hit, Rng& rng)>;

struct IlluminanceResult {
  std::vector<double> direct, total;  // lux per point
  // Under a sky (scene/sky.h): per point the lux from the sky directly (sky component, SC) and
  // from the ground and outside surfaces (externally reflected component, ERC), both in
  // `direct` too; and the unobstructed sky's horizontal illuminance, for daylight factors
  // (DF = 100 total / E_h %).
  std::vector<double> sky, external;
  double horizontal_lux = 0.0;
  IlluminanceStats direct_stats, total_stats;
  // A glare object's observers (CalculationGrid type "glare"): UGR at each, its background
  // luminance the indirect part of the vertical illuminance gathered there (total less direct,
  // daylight counted as background) over pi.
  std::vector<GlareResult> glare;
  int rays = 0;  // hemisphere rays per point
  uint64_t rays_traced = 0;
};

// E at every point of `grid` as above (cylindrical illuminance: the same with sin(angle from the
// axis) / pi for the cosine and rays uniform over the sphere), `rays` hemisphere rays per point
// (stratified in a sqrt(rays) square when it is one), points in parallel, the same result for any
// thread count.
IlluminanceResult gatherIlluminance(const Scene& scene, const RayEngine& engine,
                                    const FlatTriangles& flat, const CalculationGrid& grid,
                                    const IncidentRadiance& incident, int rays, uint64_t seed);

// What a render reports in lux: the camera's view (a value per pixel) and calculation objects.
struct IlluminanceRequest {
  bool image = false;  // lux per pixel: at the first surface each pixel's centre sees
  int width = 512, height = 512;
  int image_rays = 64;               // hemisphere rays per pixel
  std::optional<double> work_plane;  // height, m: the grid of workPlaneGrid
  std::string surface;               // or the points of surfaceGrid on this mesh
  double spacing = 0.25, margin = 0.0;
  std::vector<std::string> calc_files;    // --calc: JSON lists of calculation objects
  std::vector<std::string> points_files;  // --points: CSV or JSON points
  int grid_rays = 0;  // hemisphere rays per calculation point; 0: autoIlluminanceRays
  uint64_t seed = 0;
};

struct IlluminanceReport {
  // Every calculation object (calculationGrids' order) and its figures.
  std::vector<CalculationGrid> grids;
  std::vector<IlluminanceResult> grid_results;
  std::vector<double> image_lux;  // width x height, row-major; -1 where a pixel sees no surface
  IlluminanceResult image_result;
  double seconds = 0.0;
};

// The hemisphere rays per point an object of `points` points gets by default: the largest power
// of 4 within a budget of 2^22 rays for the object, 256 to 65,536. The indirect light at a point
// comes from the gather, whose stratified estimate of a uniformly bright surface errs where the
// strata cross its outline (the error falls as N^-3/4): at 256 rays a point that sees a floor
// over 13% of its hemisphere was 6.6% off (CIE 171 case 5.6), at 16,384 0.5%, at 65,536 0.2%.
int autoIlluminanceRays(size_t points);

// The request's calculation objects for `scene`, in order: the command line's work plane or
// surface, the --calc files' objects, the --points files' points, then the scene's own
// ("calculation"). Refuses bad values, unknown names and more than 4 million points in all,
// before any work.
Expected<std::vector<CalculationGrid>> calculationGrids(const Scene& scene,
                                                        const IlluminanceRequest& request);

// Before the work: the request's objects can be made for `scene` (as calculationGrids), with a
// warning for a work plane outside the scene.
Status checkIlluminanceRequest(const Scene& scene, const IlluminanceRequest& request);

// The request's figures for the solution `incident`; the camera's pixels measure the side of the
// surface they see.
Expected<IlluminanceReport> illuminanceReport(const Scene& scene, const RayEngine& engine,
                                              const FlatTriangles& flat, const Camera& camera,
                                              const IlluminanceRequest& request,
                                              const IncidentRadiance& incident);

// One line per point: x, y, z, direct lux, total lux (with a header); written atomically.
Status writeIlluminanceCsv(const std::string& path, const CalculationGrid& grid,
                           const IlluminanceResult& result);

// The false-colour picture of per-pixel lux (`lux` row-major width x height, negative = no
// surface: grey), 0 lux blue to `max_lux` red (<= 0: a round number above the 99th percentile),
// with a legend in lux down the right; display-linear (write with ToneMapOperator::kNone).
Image falseColourImage(std::span<const double> lux, int width, int height, double max_lux);

}  // namespace penumbra
