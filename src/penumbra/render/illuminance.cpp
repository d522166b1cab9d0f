#include "penumbra/render/illuminance.h"

#include "penumbra/core/file_util.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/kernels/sampling.h"
#include "penumbra/raytrace/camera_rays.h"
#include "penumbra/raytrace/lights.h"
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
  return kLumensPerWatt * (0.2126 * e.x + 0.7152 * e.y + 0.0722 * e.z);
}

Expected<CalculationGrid> workPlaneGrid(const Scene& scene, double height, double spacing,
                                        double margin) {
  if (!(spacing > 0.0) || !std::isfinite(spacing)) {
    return inputError("", "--grid-spacing", fmt::format("{} must be a positive length", spacing));
  }
  if (!(margin >= 0.0) || !std::isfinite(margin) || !std::isfinite(height)) {
    return inputError("", "--work-plane", "height and margin must be finite, the margin >= 0");
  }
  glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-lo);
  for (const Mesh& m : scene.meshes) {
    for (const glm::vec3& p : m.positions) {
      lo = glm::min(lo, glm::dvec3(p));
      hi = glm::max(hi, glm::dvec3(p));
    }
  }
  if (!(lo.x <= hi.x)) return inputError(scene.source, "", "the scene has no geometry");
  const double x0 = lo.x + margin, x1 = hi.x - margin, z0 = lo.z + margin, z1 = hi.z - margin;
  if (!(x1 > x0 && z1 > z0)) {
    return inputError("", "--grid-margin",
                      fmt::format("a margin of {} m leaves no area of the {:.3g} x {:.3g} m floor",
                                  margin, hi.x - lo.x, hi.z - lo.z));
  }
  const double cols = std::ceil((x1 - x0) / spacing - 1e-9);
  const double rows = std::ceil((z1 - z0) / spacing - 1e-9);
  if (cols * rows > 4e6) {
    return inputError("", "--grid-spacing",
                      fmt::format("{} m over {:.3g} x {:.3g} m makes {:.0f} points (at most 4 "
                                  "million)",
                                  spacing, x1 - x0, z1 - z0, cols * rows));
  }
  CalculationGrid g;
  g.name = fmt::format("work plane at {:.3g} m", height);
  g.columns = int(cols);
  g.rows = int(rows);
  g.spacing = spacing;
  const double dx = (x1 - x0) / cols, dz = (z1 - z0) / rows;
  for (int r = 0; r < g.rows; ++r) {
    for (int c = 0; c < g.columns; ++c) {
      g.points.emplace_back(x0 + (c + 0.5) * dx, lo.y + height, z0 + (r + 0.5) * dz);
      g.normals.emplace_back(0.0, 1.0, 0.0);
    }
  }
  return g;
}

Expected<CalculationGrid> surfaceGrid(const Scene& scene, const std::string& name, double spacing) {
  if (!(spacing > 0.0) || !std::isfinite(spacing)) {
    return inputError("", "--grid-spacing", fmt::format("{} must be a positive length", spacing));
  }
  CalculationGrid g;
  g.name = fmt::format("surface '{}'", name);
  g.spacing = spacing;
  std::string known;
  bool found = false;
  double points = 0.0;
  for (const Mesh& m : scene.meshes) {
    if (m.name != name) {
      if (known.find("'" + m.name + "'") == std::string::npos) {
        known += (known.empty() ? "'" : ", '") + m.name + "'";
      }
      continue;
    }
    found = true;
    for (const glm::uvec3& t : m.triangles) {
      const glm::dvec3 a(m.positions[t.x]), b(m.positions[t.y]), c(m.positions[t.z]);
      const double edge = std::max({glm::length(b - a), glm::length(c - b), glm::length(a - c)});
      points += std::pow(std::ceil(edge / spacing), 2.0);
    }
  }
  if (!found) {
    return inputError(scene.source, "--grid-surface",
                      fmt::format("no mesh is named '{}' (the meshes: {})", name, known));
  }
  if (points > 4e6) {
    return inputError(
        "", "--grid-spacing",
        fmt::format("{} m on '{}' makes {:.0f} points (at most 4 million)", spacing, name, points));
  }
  for (const Mesh& m : scene.meshes) {
    if (m.name != name) continue;
    for (const glm::uvec3& t : m.triangles) {
      const glm::dvec3 a(m.positions[t.x]), b(m.positions[t.y]), c(m.positions[t.z]);
      const glm::dvec3 cr = glm::cross(b - a, c - a);
      const double area2 = glm::length(cr);
      if (!(area2 > 0.0)) continue;  // degenerate: no area, no point
      const glm::dvec3 n = cr / area2;
      const int k = int(std::ceil(
          std::max({glm::length(b - a), glm::length(c - b), glm::length(a - c)}) / spacing));
      const glm::dvec3 u = (b - a) / double(k), v = (c - a) / double(k);
      const double share = 0.5 * area2 / double(k * k);
      // The k^2 similar triangles: k(k+1)/2 upright ones and k(k-1)/2 inverted.
      for (int i = 0; i < k; ++i) {
        for (int j = 0; i + j < k; ++j) {
          const glm::dvec3 o = a + double(i) * u + double(j) * v;
          g.points.push_back(o + (u + v) / 3.0);
          g.normals.push_back(n);
          g.areas.push_back(share);
          if (i + j + 1 < k) {
            g.points.push_back(o + 2.0 * (u + v) / 3.0);
            g.normals.push_back(n);
            g.areas.push_back(share);
          }
        }
      }
    }
  }
  g.columns = int(g.points.size());
  g.rows = 1;
  return g;
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
  return s;
}

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
  const int strata = int(std::lround(std::sqrt(double(out.rays))));
  const bool square = strata * strata == out.rays;
  std::atomic<uint64_t> traced{0};
  parallelRange(n, 16, [&](size_t begin, size_t end) {
    uint64_t count = 0;
    for (size_t i = begin; i < end; ++i) {
      const glm::dvec3 p = grid.points[i], nrm = grid.normals[i];
      const glm::dvec3 from = p + nrm * lift;
      glm::dvec3 delta(0.0);
      for (const Light& light : scene.lights) {
        const LightSample s = sampleLight(light, p, nrm, nrm);
        if (s.irradiance == glm::dvec3(0.0)) continue;
        const bool far = s.distance > 1e30;
        const Ray ray{glm::vec3(from), 1e-4f,
                      far ? glm::vec3(s.direction) : glm::vec3(s.direction * s.distance),
                      far ? std::numeric_limits<float>::max() : 1.0f - 1e-4f};
        ++count;
        if (!engine.occluded(ray)) delta += s.irradiance;
      }
      // The directions from one stream, the solution's estimator (a path tracer) from another:
      // every method gathers along the same rays, so their direct parts are equal and their
      // totals differ only by what the solutions differ by.
      Rng rng(mixBits(seed), i);
      Rng incident_rng(mixBits(seed ^ 0x1a5eed), i);
      const Frame frame = Frame::fromNormal(glm::vec3(nrm));
      glm::dvec3 gathered(0.0), emitted(0.0);
      for (int k = 0; k < out.rays; ++k) {
        const float u1 =
            square ? (float(k % strata) + rng.uniform()) / float(strata) : rng.uniform();
        const float u2 =
            square ? (float(k / strata) + rng.uniform()) / float(strata) : rng.uniform();
        const glm::vec3 d = frame.toWorld(sampleCosineHemisphere(u1, u2));
        const Ray ray{glm::vec3(from), float(lift), d, std::numeric_limits<float>::max()};
        const Hit hit = engine.intersect(ray);
        ++count;
        gathered += glm::dvec3(incident(ray, hit, incident_rng));
        if (hit.hit()) {
          const glm::uvec3 t = flat.triangles[size_t(hit.triangle)];
          const glm::vec3 ng = glm::cross(flat.positions[t.y] - flat.positions[t.x],
                                          flat.positions[t.z] - flat.positions[t.x]);
          const Material& m = scene.materials[flat.material_ids[size_t(hit.triangle)]];
          if (glm::dot(ng, d) < 0.0f) emitted += glm::dvec3(m.emission);  // front faces emit
        }
      }
      const double w = out.rays > 0 ? std::numbers::pi / double(out.rays) : 0.0;
      out.direct[i] = luxOf(delta + w * emitted);
      out.total[i] = luxOf(delta + w * gathered);
    }
    traced += count;
  });
  out.rays_traced = traced.load();
  out.direct_stats = illuminanceStats(out.direct, grid.areas);
  out.total_stats = illuminanceStats(out.total, grid.areas);
  return out;
}

Status checkIlluminanceRequest(const Scene& scene, const IlluminanceRequest& request) {
  if (request.work_plane) {
    Expected<CalculationGrid> g =
        workPlaneGrid(scene, *request.work_plane, request.spacing, request.margin);
    if (!g) return g.error();
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
  } else if (!request.surface.empty()) {
    Expected<CalculationGrid> g = surfaceGrid(scene, request.surface, request.spacing);
    if (!g) return g.error();
  }
  return {};
}

Expected<IlluminanceReport> illuminanceReport(const Scene& scene, const RayEngine& engine,
                                              const FlatTriangles& flat, const Camera& camera,
                                              const IlluminanceRequest& request,
                                              const IncidentRadiance& incident) {
  const Timer timer;
  IlluminanceReport report;
  if (request.work_plane || !request.surface.empty()) {
    Expected<CalculationGrid> g =
        request.work_plane
            ? workPlaneGrid(scene, *request.work_plane, request.spacing, request.margin)
            : surfaceGrid(scene, request.surface, request.spacing);
    if (!g) return g.error();
    report.grid = std::move(*g);
    report.grid_result = gatherIlluminance(scene, engine, flat, *report.grid, incident,
                                           request.grid_rays, request.seed);
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
