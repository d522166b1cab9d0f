// Photometric output for lighting design: illuminance in lux on calculation points (a work plane,
// the points a camera sees) from any method's solution, with the figures lighting designers
// report (EN 12464-1): average, minimum, maximum and uniformity U0 = E_min / E_avg, direct and
// total separately; CSV tables and false-colour pictures with a legend in lux.
//
// Lux are 683 lm/W (Wallner eq. 12, the luminaires' own conversion, scene/luminaire.h) times the
// irradiance's luminance (Rec. 709 weights), so a luminaire gives the lux its file promises.
//
// The illuminance at a point x with normal n is gathered, whatever method made the solution:
//   E(x) = sum over delta lights of E_light V (a shadow ray each, as the radiosity methods shoot)
//        + pi / N sum over N stratified cosine-distributed directions of L(x, w),
// where L is the method's radiance along the ray (the lightmap of a radiosity solution, which
// holds emitters' emission and all interreflection, or the path tracer's estimate). The direct
// part is the delta lights plus, from the same rays, the emission of the emitters they hit.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/core/rng.h"
#include "penumbra/kernels/ray.h"
#include "penumbra/raytrace/ray_engine.h"
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

// Calculation points, each with the normal of the surface it measures.
struct CalculationGrid {
  std::string name;
  int columns = 0, rows = 0;  // a plane's points, row-major (rows = 1 for a list)
  std::vector<glm::dvec3> points;
  std::vector<glm::dvec3> normals;
  double spacing = 0.0;  // metres between neighbouring points of a plane
  // The area each point stands for, m^2, when the points are not evenly spread (a surface's);
  // empty: equal shares. The figures' average is weighted by it.
  std::vector<double> areas;
};

// A horizontal work plane facing up, `height` metres above the scene's lowest point, over the
// scene's extent in x and z less `margin` on each side: points at the centres of square cells
// of about `spacing` (the count rounded up so the cells fit the area exactly). Refuses a
// non-positive spacing, an area that the margin leaves empty, and more than 4 million points.
Expected<CalculationGrid> workPlaneGrid(const Scene& scene, double height, double spacing,
                                        double margin);

// The front faces of the meshes named `name` (a JSON scene's mesh "name", or a file's own
// mesh names), each triangle split into n^2 similar triangles with n = its longest edge /
// `spacing` rounded up: a point at each one's centroid, facing out of the front, standing for
// its area. Refuses an unknown name (listing the known ones), a bad spacing and more than 4
// million points.
Expected<CalculationGrid> surfaceGrid(const Scene& scene, const std::string& name, double spacing);

// The figures of a set of illuminance values, lux: the average (weighted by `areas` when given),
// minimum, maximum, and the uniformity U0 = minimum / average (0 when the average is 0).
struct IlluminanceStats {
  double average = 0.0, minimum = 0.0, maximum = 0.0, uniformity = 0.0;
};
IlluminanceStats illuminanceStats(std::span<const double> lux, std::span<const double> areas = {});

// Radiance (W m^-2 sr^-1) arriving along `ray` whose closest hit is `hit` (a miss: triangle -1),
// from the method's solution; `rng` for estimators that need random numbers.
using IncidentRadiance = std::function<glm::vec3(const Ray& ray, const Hit& hit, Rng& rng)>;

struct IlluminanceResult {
  std::vector<double> direct, total;  // lux per point
  IlluminanceStats direct_stats, total_stats;
  int rays = 0;  // hemisphere rays per point
  uint64_t rays_traced = 0;
};

// E at every point of `grid` as above, `rays` hemisphere rays per point (stratified in a
// sqrt(rays) square when it is one), points in parallel, the same result for any thread count.
IlluminanceResult gatherIlluminance(const Scene& scene, const RayEngine& engine,
                                    const FlatTriangles& flat, const CalculationGrid& grid,
                                    const IncidentRadiance& incident, int rays, uint64_t seed);

// What a render reports in lux: the camera's view (a value per pixel) and a work plane.
struct IlluminanceRequest {
  bool image = false;  // lux per pixel: at the first surface each pixel's centre sees
  int width = 512, height = 512;
  int image_rays = 64;               // hemisphere rays per pixel
  std::optional<double> work_plane;  // height, m: the grid of workPlaneGrid
  std::string surface;               // or the points of surfaceGrid on this mesh
  double spacing = 0.25, margin = 0.0;
  int grid_rays = 256;  // hemisphere rays per grid point
  uint64_t seed = 0;
};

struct IlluminanceReport {
  std::optional<CalculationGrid> grid;
  IlluminanceResult grid_result;
  std::vector<double> image_lux;  // width x height, row-major; -1 where a pixel sees no surface
  IlluminanceResult image_result;
  double seconds = 0.0;
};

// Before the work: the request's grid can be made for `scene` (a bad height, spacing, margin or
// surface name is refused here, not after a solve).
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
