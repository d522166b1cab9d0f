#include "penumbra/render/illuminance.h"

#include "penumbra/core/color.h"
#include "penumbra/core/file_util.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/kernels/sampling.h"
#include "penumbra/raytrace/camera_rays.h"
#include "penumbra/raytrace/daylight_gather.h"
#include "penumbra/raytrace/lights.h"
#include "penumbra/render/direct_emitters.h"
#include "penumbra/render/plot.h"
#include "penumbra/scene/luminaire.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>

namespace penumbra {

double luxOf(const glm::dvec3& e) {
  return kLumensPerWatt * luminance(e);
}

IlluminanceStats illuminanceStats(std::span<const double> lux, std::span<const double> areas) {
  IlluminanceStats s;
  if (lux.empty()) return s;
  double sum = 0.0, weight = 0.0;
  s.minimum = std::numeric_limits<double>::infinity();
  s.maximum = -s.minimum;
  for (size_t i = 0; i < lux.size(); ++i) {
    const double w = areas.empty() ? 1.0 : areas[i];
    sum += w * lux[i];
    weight += w;
    s.minimum = std::min(s.minimum, lux[i]);
    s.maximum = std::max(s.maximum, lux[i]);
  }
  s.average = weight > 0.0 ? sum / weight : 0.0;
  s.uniformity = s.average > 0.0 ? s.minimum / s.average : 0.0;
  s.uniformity_u1 = s.maximum > 0.0 ? s.minimum / s.maximum : 0.0;
  return s;
}

namespace {

// The delta lights' irradiance at p (facing n, or cylindrical about n), a shadow ray each from
// `from`.
glm::dvec3 deltaLightIrradiance(const Scene& scene, const RayEngine& engine, const glm::dvec3& p,
                                const glm::dvec3& n, const glm::dvec3& from, bool cylindrical,
                                uint64_t& count) {
  glm::dvec3 e(0.0);
  for (const Light& light : scene.lights) {
    LightSample s = sampleLight(light, p, n, n);
    if (cylindrical) {
      // The intensity over the squared distance (the light's normal irradiance), times
      // sin(angle from the axis) / pi.
      s = sampleLight(light, p, s.direction, s.direction);
      const double c = glm::dot(s.direction, n);
      s.irradiance *= std::sqrt(std::max(0.0, 1.0 - c * c)) / std::numbers::pi;
    }
    if (s.irradiance == glm::dvec3(0.0)) continue;
    const bool far = s.distance > 1e30;
    const Ray ray{glm::vec3(from), 1e-4f,
                  far ? glm::vec3(s.direction) : glm::vec3(s.direction * s.distance),
                  far ? std::numeric_limits<float>::max() : 1.0f - 1e-4f};
    ++count;
    if (engine.occluded(ray)) continue;
    // Through glazed openings (a sun patch behind a window): their transmittance at the angle.
    e += s.irradiance *
         transmittanceThrough(scene.openings, from, s.direction,
                              far ? std::numeric_limits<double>::infinity() : s.distance);
  }
  return e;
}

// What the hemisphere (or sphere) rays of one point gather, each sum already times its ray's
// weight: the solution's radiance less the emission counted exactly, the emission of emitters
// the closed form does not take, and, without openings, the sky and ground the rays find.
struct Gathered {
  glm::dvec3 solution{0.0}, emitted{0.0}, sky{0.0}, ground{0.0};
};

struct GatherContext {
  const Scene& scene;
  const RayEngine& engine;
  const FlatTriangles& flat;
  const IncidentRadiance& incident;
  const AreaEmitters& emitters;
  const OpeningLight& openings;
  bool open_sky;  // a sky and no openings: the rays that leave see it
  int rays;
  double lift;
};

// The rays from `from` of a point facing n: cosine-distributed over the hemisphere for planar
// illuminance (E = pi mean L), uniform over the sphere for cylindrical (E_z = 4 mean L
// sin(angle from the axis)), stratified in a sqrt(rays) square when it is one. The directions
// come from `rng`, the solution's estimator (a path tracer) from `incident_rng`: every method
// gathers along the same rays, so their direct parts are equal and their totals differ only by
// what the solutions differ by.
Gathered gatherRays(const GatherContext& c, const glm::dvec3& from, const glm::dvec3& n,
                    bool cylindrical, Rng& rng, Rng& incident_rng, uint64_t& count) {
  Gathered g;
  const int strata = int(std::lround(std::sqrt(double(c.rays))));
  const bool square = strata * strata == c.rays;
  const Frame frame = Frame::fromNormal(glm::vec3(n));
  for (int k = 0; k < c.rays; ++k) {
    const float u1 = square ? (float(k % strata) + rng.uniform()) / float(strata) : rng.uniform();
    const float u2 = square ? (float(k / strata) + rng.uniform()) / float(strata) : rng.uniform();
    glm::vec3 d;
    double weight = 1.0;
    if (cylindrical) {
      const float z = 1.0f - 2.0f * u1, r = std::sqrt(std::max(0.0f, 1.0f - z * z));
      const float phi = 2.0f * kPi * u2;
      d = frame.toWorld(glm::vec3(r * std::cos(phi), r * std::sin(phi), z));
      weight = 4.0 * double(r);  // (4 pi / pi) sin, the 1 / N applied by the caller
    } else {
      d = frame.toWorld(sampleCosineHemisphere(u1, u2));
    }
    const Ray ray{glm::vec3(from), float(c.lift), d, std::numeric_limits<float>::max()};
    const Hit hit = c.engine.intersect(ray);
    ++count;
    // What leaves through an opening was counted on the opening.
    if (c.openings.active() && c.openings.crosses(ray, hit.hit() ? hit.t : ray.tmax)) continue;
    if (!hit.hit() && c.open_sky) {
      const glm::dvec3 l(c.scene.sky->radiance(glm::dvec3(d)));
      (d.y >= 0.0f ? g.sky : g.ground) += weight * l;
      continue;
    }
    // A ray that leaves the scene sees the uniform environment, whatever the method's solution
    // holds (a lightmap has nothing to look up there); with a sky, as above or through openings.
    glm::dvec3 l = !hit.hit() && !c.scene.sky ? glm::dvec3(c.scene.environment)
                                              : glm::dvec3(c.incident(ray, hit, incident_rng));
    if (hit.hit()) {
      const glm::uvec3 t = c.flat.triangles[size_t(hit.triangle)];
      const glm::vec3 ng = glm::cross(c.flat.positions[t.y] - c.flat.positions[t.x],
                                      c.flat.positions[t.z] - c.flat.positions[t.x]);
      const Material& m = c.scene.materials[c.flat.material_ids[size_t(hit.triangle)]];
      if (glm::dot(ng, d) < 0.0f) {  // front faces emit
        if (c.emitters.handles(uint32_t(hit.triangle))) {
          l = glm::max(l - glm::dvec3(m.emission), glm::dvec3(0.0));
        } else {
          g.emitted += weight * glm::dvec3(m.emission);
        }
      }
    }
    g.solution += weight * l;
  }
  return g;
}

}  // namespace

IlluminanceResult gatherIlluminance(const Scene& scene, const RayEngine& engine,
                                    const FlatTriangles& flat, const CalculationGrid& grid,
                                    const IncidentRadiance& incident, int rays, uint64_t seed) {
  IlluminanceResult out;
  out.rays = std::max(rays, 0);
  const size_t n = grid.points.size();
  out.direct.assign(n, 0.0);
  out.total.assign(n, 0.0);
  glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-lo);
  for (const glm::vec3& p : flat.positions) {
    lo = glm::min(lo, glm::dvec3(p));
    hi = glm::max(hi, glm::dvec3(p));
  }
  const double lift = lo.x <= hi.x ? 1e-5 * glm::length(hi - lo) : 1e-5;
  const bool cylindrical = grid.measure == Measure::kCylindrical;
  const AreaEmitters emitters(scene, flat);
  const OpeningLight openings(scene);
  const bool daylight = scene.sky.has_value();
  if (daylight) {
    out.horizontal_lux = scene.sky->horizontalIlluminance();
    out.sky.assign(n, 0.0);
    out.external.assign(n, 0.0);
  }
  // Without openings, the sky is what the gather's rays find when they leave the scene.
  const GatherContext context{
      scene,    engine, flat, incident, emitters, openings, daylight && !openings.active(),
      out.rays, lift};
  std::atomic<uint64_t> traced{0};
  parallelRange(n, 16, [&](size_t begin, size_t end) {
    uint64_t count = 0;
    for (size_t i = begin; i < end; ++i) {
      const glm::dvec3 p = grid.points[i], nrm = grid.normals[i];
      const glm::dvec3 from = p + nrm * lift;
      // The exact part: delta lights with a shadow ray each, area emitters in closed form times
      // their visible share (render/direct_emitters.h), each from a stream of its own.
      glm::dvec3 exact = deltaLightIrradiance(scene, engine, p, nrm, from, cylindrical, count);
      Rng direct_rng(mixBits(seed ^ 0xd12ec7), i);
      exact += cylindrical ? emitters.cylindricalIrradiance(engine, p, nrm, lift, direct_rng, count)
                           : emitters.irradiance(engine, p, nrm, lift, direct_rng, count);
      // Daylight through the openings (render/daylight_gather.h): the sky and what is outside,
      // sampled on the openings, as many points as the gather has rays.
      DaylightIrradiance day;
      if (openings.active()) {
        Rng day_rng(mixBits(seed ^ 0xda7119), i);
        day = openings.irradiance(engine, p, nrm, lift, std::max(out.rays, 16), cylindrical,
                                  day_rng, incident, count);
      }
      // The rest from the solution.
      Rng rng(mixBits(seed), i);
      Rng incident_rng(mixBits(seed ^ 0x1a5eed), i);
      const Gathered g = gatherRays(context, from, nrm, cylindrical, rng, incident_rng, count);
      const double w =
          out.rays > 0 ? (cylindrical ? 1.0 : std::numbers::pi) / double(out.rays) : 0.0;
      const glm::dvec3 sky = day.sky + w * g.sky;
      const glm::dvec3 outside = day.external + w * g.ground;
      out.direct[i] = luxOf(exact + w * g.emitted + sky + outside);
      out.total[i] = luxOf(exact + w * g.solution + sky + outside);
      if (daylight) {
        out.sky[i] = luxOf(sky);
        out.external[i] = luxOf(outside);
      }
    }
    traced += count;
  });
  out.rays_traced = traced.load();
  out.direct_stats = illuminanceStats(out.direct, grid.areas);
  out.total_stats = illuminanceStats(out.total, grid.areas);
  return out;
}

int autoIlluminanceRays(size_t points) {
  int rays = 65536;
  while (rays > 256 && double(rays) * double(points) > double(1 << 22)) rays /= 4;
  return rays;
}

Expected<std::vector<CalculationGrid>> calculationGrids(const Scene& scene,
                                                        const IlluminanceRequest& request) {
  std::vector<CalculationGrid> grids;
  if (request.work_plane) {
    Expected<CalculationGrid> g =
        workPlaneGrid(scene, *request.work_plane, request.spacing, request.margin);
    if (!g) return g.error();
    grids.push_back(std::move(*g));
  } else if (!request.surface.empty()) {
    Expected<CalculationGrid> g = surfaceGrid(scene, request.surface, request.spacing);
    if (!g) return g.error();
    grids.push_back(std::move(*g));
  }
  for (const std::string& file : request.calc_files) {
    Expected<std::vector<CalculationGrid>> list = readCalculationFile(scene, file);
    if (!list) return list.error();
    for (CalculationGrid& g : *list) grids.push_back(std::move(g));
  }
  for (const std::string& file : request.points_files) {
    Expected<CalculationGrid> g = readCalculationPoints(file);
    if (!g) return g.error();
    grids.push_back(std::move(*g));
  }
  for (const CalculationGrid& g : scene.calculation) grids.push_back(g);
  size_t total = 0;
  for (const CalculationGrid& g : grids) total += g.points.size();
  if (total > kMaxCalculationPoints) {
    return inputError("", "--calc",
                      fmt::format("the calculation objects make {} points in all (at most 4 "
                                  "million)",
                                  total));
  }
  return grids;
}

Status checkIlluminanceRequest(const Scene& scene, const IlluminanceRequest& request) {
  Expected<std::vector<CalculationGrid>> grids = calculationGrids(scene, request);
  if (!grids) return grids.error();
  if (request.work_plane) {
    // A plane above everything or below the floor is legal (an open site) but usually a slip of
    // units: its lux would be read as the room's.
    float lo = std::numeric_limits<float>::infinity(), hi = -lo;
    for (const Mesh& m : scene.meshes) {
      for (const glm::vec3& p : m.positions) {
        lo = std::min(lo, p.y);
        hi = std::max(hi, p.y);
      }
    }
    const double height = *request.work_plane;
    if (height < 0.0 || height > double(hi - lo)) {
      spdlog::warn(
          "--work-plane {:g} m lies outside the scene, whose geometry spans {:.3g} m "
          "above its lowest point: the grid sees the scene from outside",
          height, double(hi - lo));
    }
  }
  return {};
}

Expected<IlluminanceReport> illuminanceReport(const Scene& scene, const RayEngine& engine,
                                              const FlatTriangles& flat, const Camera& camera,
                                              const IlluminanceRequest& request,
                                              const IncidentRadiance& incident) {
  const Timer timer;
  IlluminanceReport report;
  Expected<std::vector<CalculationGrid>> grids = calculationGrids(scene, request);
  if (!grids) return grids.error();
  report.grids = std::move(*grids);
  for (const CalculationGrid& g : report.grids) {
    const int rays =
        request.grid_rays > 0 ? request.grid_rays : autoIlluminanceRays(g.points.size());
    report.grid_results.push_back(
        gatherIlluminance(scene, engine, flat, g, incident, rays, request.seed));
    if (g.type == "glare") {
      IlluminanceResult& r = report.grid_results.back();
      for (size_t i = 0; i < g.points.size(); ++i) {
        double background = r.total[i] - r.direct[i];
        if (!r.sky.empty()) background += r.sky[i] + r.external[i];
        r.glare.push_back(glareAt(scene, engine, flat, g.points[i], g.normals[i],
                                  std::max(0.0, background) / std::numbers::pi, request.seed + i));
      }
    }
  }
  if (request.image) {
    // One point per pixel centre on the surface it sees, facing the camera.
    const CameraRays rays(camera, request.width, request.height);
    const size_t pixels = size_t(request.width) * size_t(request.height);
    std::vector<int64_t> point_of(pixels, -1);
    CalculationGrid seen;
    seen.name = "camera view";
    for (int y = 0; y < request.height; ++y) {
      for (int x = 0; x < request.width; ++x) {
        const Ray ray = rays.ray(float(x) + 0.5f, float(y) + 0.5f);
        const Hit hit = engine.intersect(ray);
        if (!hit.hit()) continue;
        const glm::uvec3 t = flat.triangles[size_t(hit.triangle)];
        glm::dvec3 n = glm::normalize(glm::dvec3(glm::cross(
            flat.positions[t.y] - flat.positions[t.x], flat.positions[t.z] - flat.positions[t.x])));
        if (glm::dot(n, glm::dvec3(ray.dir)) > 0.0) n = -n;
        point_of[size_t(y) * size_t(request.width) + size_t(x)] = int64_t(seen.points.size());
        seen.points.push_back(glm::dvec3(ray.origin) + double(hit.t) * glm::dvec3(ray.dir));
        seen.normals.push_back(n);
      }
    }
    seen.columns = int(seen.points.size());
    seen.rows = 1;
    report.image_result =
        gatherIlluminance(scene, engine, flat, seen, incident, request.image_rays, request.seed);
    report.image_lux.assign(pixels, -1.0);
    for (size_t p = 0; p < pixels; ++p) {
      if (point_of[p] >= 0) report.image_lux[p] = report.image_result.total[size_t(point_of[p])];
    }
  }
  report.seconds = timer.seconds();
  return report;
}

Status writeIlluminanceCsv(const std::string& path, const CalculationGrid& grid,
                           const IlluminanceResult& result) {
  return writeAtomically(path, [&](const std::string& tmp) -> Status {
    std::FILE* f = std::fopen(tmp.c_str(), "w");
    if (!f) return runtimeError(path, "cannot write the illuminance table");
    std::fprintf(f, "# %s: %d x %d points, %d hemisphere rays each\n", grid.name.c_str(),
                 grid.columns, grid.rows, result.rays);
    std::fprintf(f, "x_m,y_m,z_m,direct_lux,total_lux\n");
    for (size_t i = 0; i < grid.points.size(); ++i) {
      const glm::dvec3& p = grid.points[i];
      std::fprintf(f, "%.4f,%.4f,%.4f,%.3f,%.3f\n", p.x, p.y, p.z, result.direct[i],
                   result.total[i]);
    }
    const bool ok = std::ferror(f) == 0;
    if (std::fclose(f) != 0 || !ok) return runtimeError(path, "cannot write the table");
    return {};
  });
}

Image falseColourImage(std::span<const double> lux, int width, int height, double max_lux) {
  if (!(max_lux > 0.0)) {
    std::vector<double> seen;
    for (double v : lux) {
      if (v >= 0.0) seen.push_back(v);
    }
    double p99 = 0.0;
    if (!seen.empty()) {
      const size_t k = size_t(0.99 * double(seen.size() - 1));
      std::nth_element(seen.begin(), seen.begin() + ptrdiff_t(k), seen.end());
      p99 = seen[k];
    }
    max_lux = niceCeiling(p99);
  }
  // The picture, then a legend band on the right: a colour bar with ticks in lux.
  const int scale = height >= 384 ? 2 : 1;
  const int legend = 40 + Canvas::textWidth("00000 lx", scale);
  Canvas canvas(width + legend, height, glm::vec3(1.0f));
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double v = lux[size_t(y) * size_t(width) + size_t(x)];
      canvas.image().at(x, y) = v < 0.0 ? glm::vec3(0.35f) : falseColour(float(v / max_lux));
    }
  }
  const int bar_x = width + 8, bar_w = 14, top = 10 + 4 * scale, bottom = height - 10 - 4 * scale;
  for (int y = top; y < bottom; ++y) {
    const float t = float(bottom - 1 - y) / float(std::max(1, bottom - top - 1));
    canvas.fillRect(bar_x, y, bar_x + bar_w, y + 1, falseColour(t));
  }
  const glm::vec3 ink(0.0f);
  for (int k = 0; k <= 4; ++k) {
    const int y = bottom - 1 - int(std::lround(double(bottom - top - 1) * k / 4.0));
    canvas.fillRect(bar_x + bar_w, y, bar_x + bar_w + 4, y + 1, ink);
    const double value = max_lux * k / 4.0;
    canvas.text(bar_x + bar_w + 6, y - 3 * scale, fmt::format("{:g} lx", value), ink, scale);
  }
  return canvas.image();
}

}  // namespace penumbra
