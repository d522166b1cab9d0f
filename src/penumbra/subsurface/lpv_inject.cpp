// Injection of subsurface light propagation volumes (Børlum et al. 2011, sec. 3.1): the light
// entering a translucent object's boundary becomes virtual point lights in its boundary cells.
//
//  - Lights (the paper's method): a reflective shadow map per light, traced through the Ray
//    Engine; each texel that sees the object's front sends the flux Phi_p through the boundary.
//  - Emitting surfaces and the environment (not in the paper, which has point and directional
//    lights only; needed for any scene lit by area lights or a sky, and to compare with the path
//    tracer, whose random walk cannot see point lights through a smooth boundary): the
//    irradiance gathered at stratified points of the object's surface, `surface_rays`
//    cosine-distributed rays each, a ray that meets an emitter's front or leaves the scene
//    bringing its radiance L: a direction sample carries the flux pi L A_x / rays into the
//    boundary. (Light other surfaces reflect onto the object is not gathered, as the paper's
//    maps do not.)
//
// Either way a virtual point light has the intensity (1 / pi) T Phi max(0, w_t . w) about the
// refracted direction w_t (eq. 1, T the Fresnel transmittance), projected on the two SH bands and
// summed into the boundary cell that holds its surface point.
#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/kernels/dipole.h"
#include "penumbra/kernels/sampling.h"
#include "penumbra/raytrace/lights.h"
#include "penumbra/subsurface/lpv.h"
#include "penumbra/subsurface/lpv_sh.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <variant>

namespace penumbra {

namespace {

// The refracted direction of `d` (unit, travelling into the surface of outward unit normal n)
// entering a medium of relative index eta (Snell's law; eta >= 1, so no total reflection).
glm::dvec3 refractInto(const glm::dvec3& d, const glm::dvec3& n, double eta) {
  const double cos_i = std::clamp(-glm::dot(d, n), 0.0, 1.0);
  const double sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
  const double cos_t = std::sqrt(std::max(0.0, 1.0 - sin2_t));
  return glm::normalize(d / eta + (cos_i / eta - cos_t) * n);
}

// The object's cell a virtual point light at surface point p (outward normal n) goes into: the
// cell holding p, or the one half a cell inside when that one is outside. None when both are
// outside (the surface grazing a cell's corner): its light would not propagate.
std::optional<size_t> injectionCell(const LpvObject& o, const glm::dvec3& p, const glm::dvec3& n) {
  glm::ivec3 cell = o.grid.cellOf(p);
  if (o.cells[o.grid.index(cell)] == LpvCell::kOutside) {
    cell = o.grid.cellOf(p - n * (0.5 * o.grid.cell));
  }
  if (o.cells[o.grid.index(cell)] == LpvCell::kOutside) return std::nullopt;
  return o.grid.index(cell);
}

}  // namespace

void LpvSolver::inject(const Scene& scene, LpvObject& o, uint32_t index, uint64_t* texels) {
  // Injection reaches only the object's cells: setting them sets the field. The light of the
  // emitters and the environment first (kept while they and the geometry stay).
  for (const uint32_t i : o.transfer.cells) {
    for (size_t ch = 0; ch < 3; ++ch) o.injected.c[ch][i] = o.surroundings.c[ch][i];
  }
  const Mesh& mesh = scene.meshes[o.mesh];
  const Bounds3 bounds = Bounds3::of(mesh.positions);
  const glm::dvec3 centre(bounds.center());
  const double radius = 0.5 * double(glm::length(bounds.extent())) * 1.001 + 1e-9;
  const int n = options_.rsm_resolution;
  const double eta = o.medium.eta;
  // Per row of the map, the virtual point lights found, summed into the grid in row order so that
  // the result does not depend on the threads.
  struct Vpl {
    size_t cell;
    glm::dvec3 flux;       // T Phi_p per channel
    glm::dvec3 direction;  // w_t
  };
  for (const Light& light : scene.lights) {
    // The map's frame: a perspective frustum from the light around the object's bounding sphere,
    // or, for a directional light, an orthographic square across it.
    glm::dvec3 axis, origin;
    bool ortho = false;
    std::visit(Overloaded{[&](const DirectionalLight& d) {
                            ortho = true;
                            axis = glm::normalize(glm::dvec3(d.direction));
                          },
                          [&](const auto& l) {
                            origin = glm::dvec3(l.position);
                            axis = centre - origin;
                          }},
               light);
    const double distance = ortho ? 0.0 : glm::length(axis);
    if (!ortho) {
      if (!(distance > radius)) continue;  // a light inside the object's bounds: no map
      axis /= distance;
    }
    const glm::dvec3 helper =
        std::abs(axis.x) < 0.9 ? glm::dvec3(1.0, 0.0, 0.0) : glm::dvec3(0.0, 1.0, 0.0);
    const glm::dvec3 right = glm::normalize(glm::cross(axis, helper));
    const glm::dvec3 up = glm::cross(right, axis);
    // Half-extent of the map's plane: tan(FOV / 2) at unit distance, or the sphere's radius.
    const double half = ortho ? radius : radius / std::sqrt(distance * distance - radius * radius);
    if (ortho) origin = centre - axis * (2.0 * radius);
    std::vector<std::vector<Vpl>> rows(static_cast<size_t>(n));
    std::atomic<uint64_t> count{0};
    parallelRange(size_t(n), 1, [&](size_t y0, size_t y1) {
      for (size_t y = y0; y < y1; ++y) {
        for (int x = 0; x < n; ++x) {
          const double u = half * (2.0 * (x + 0.5) / n - 1.0);
          const double v = half * (2.0 * (double(y) + 0.5) / n - 1.0);
          Ray ray;
          glm::dvec3 dir;
          double solid_angle = 0.0, texel_area = 0.0;
          if (ortho) {
            dir = axis;
            ray.origin = glm::vec3(origin + u * right + v * up);
            texel_area = (2.0 * half / n) * (2.0 * half / n);
          } else {
            const glm::dvec3 through = axis + u * right + v * up;
            dir = glm::normalize(through);
            ray.origin = glm::vec3(origin);
            // Sec. 3.1: Delta w_p = 4 alpha tan^2(FOV / 2) cos^3 theta_p / (N_x N_y).
            const double cos_p = glm::dot(dir, axis);
            solid_angle = 4.0 * half * half * cos_p * cos_p * cos_p / (double(n) * double(n));
          }
          ray.dir = glm::vec3(dir);
          ray.tmin = 0.0f;
          ray.tmax = std::numeric_limits<float>::max();
          const Hit hit = engine_.intersect(ray);
          if (!hit.hit() || triangle_object_[size_t(hit.triangle)] != index + 1) continue;
          const glm::uvec3 tri = flat_.triangles[size_t(hit.triangle)];
          const glm::dvec3 a(flat_.positions[tri.x]), b(flat_.positions[tri.y]),
              c(flat_.positions[tri.z]);
          glm::dvec3 normal = glm::normalize(glm::cross(b - a, c - a));
          if (glm::dot(normal, dir) >= 0.0) continue;  // the inside of the surface
          const glm::dvec3 p = glm::dvec3(ray.origin) + double(hit.t) * dir;
          // The flux through the texel: the light's irradiance across the ray times the
          // texel's area there (I Delta w_p for lights at a point).
          const LightSample ls = sampleLight(light, p, -dir, -dir);
          const glm::dvec3 flux = ortho ? ls.irradiance * texel_area
                                        : ls.irradiance * ls.distance * ls.distance * solid_angle;
          if (flux == glm::dvec3(0.0)) continue;
          const double cos_i = -glm::dot(dir, normal);
          const double t = fresnelTransmittance(eta, cos_i);
          const std::optional<size_t> cell = injectionCell(o, p, normal);
          if (!cell) continue;
          rows[y].push_back({*cell, t * flux, refractInto(dir, normal, eta)});
        }
        count += rows[y].size();
      }
    });
    for (const std::vector<Vpl>& row : rows) {
      for (const Vpl& vpl : row) {
        // Eq. 1: (1 / pi) T Phi_p max(0, w_t . w), on the two bands.
        const glm::dvec4 lobe = lpvCosineLobe(vpl.direction) / std::numbers::pi;
        for (int ch = 0; ch < 3; ++ch) {
          o.injected.c[size_t(ch)][vpl.cell] += glm::vec4(lobe * vpl.flux[ch]);
        }
      }
    }
    if (texels) *texels += count.load();
  }
}

bool LpvSolver::hasSurroundings(const Scene& scene) {
  if (scene.environment != glm::vec3(0.0f)) return true;
  for (const Material& m : scene.materials) {
    if (m.isEmissive()) return true;
  }
  return false;
}

void LpvSolver::injectSurroundings(const Scene& scene, LpvObject& o, uint32_t index) {
  o.surroundings.resize(o.grid.cellCount());
  const int points = options_.surface_samples, rays = options_.surface_rays;
  if (!hasSurroundings(scene) || points == 0 || rays == 0) return;
  // The object's triangles and their cumulative areas.
  std::vector<uint32_t> triangles;
  std::vector<double> cdf;
  double area = 0.0;
  for (size_t t = 0; t < flat_.triangles.size(); ++t) {
    if (triangle_object_[t] != index + 1) continue;
    const glm::uvec3 tri = flat_.triangles[t];
    const glm::dvec3 a(flat_.positions[tri.x]), b(flat_.positions[tri.y]),
        c(flat_.positions[tri.z]);
    area += 0.5 * glm::length(glm::cross(b - a, c - a));
    triangles.push_back(uint32_t(t));
    cdf.push_back(area);
  }
  if (!(area > 0.0)) return;
  const double eta = o.medium.eta;
  // Per point, the sum of its rays' lobes per channel, summed into the grid in point order so
  // that the result does not depend on the threads.
  struct Point {
    size_t cell = std::numeric_limits<size_t>::max();
    glm::dvec4 c[3];
  };
  std::vector<Point> found(static_cast<size_t>(points));
  const double share = std::numbers::pi * area / double(points) / double(rays);
  parallelRange(size_t(points), 64, [&](size_t k0, size_t k1) {
    for (size_t k = k0; k < k1; ++k) {
      Rng rng(mixBits(0x5eed5u + index), k);
      // Stratified over the area: point k in the k-th 1 / points of it.
      const double u = (double(k) + double(rng.uniform())) / double(points) * area;
      const size_t pick = size_t(std::lower_bound(cdf.begin(), cdf.end(), u) - cdf.begin());
      const glm::uvec3 tri = flat_.triangles[triangles[std::min(pick, triangles.size() - 1)]];
      const glm::vec3 a = flat_.positions[tri.x], b = flat_.positions[tri.y],
                      c = flat_.positions[tri.z];
      const glm::vec2 bary = sampleTriangleBarycentrics(rng.uniform(), rng.uniform());
      const glm::vec3 p = a + bary.x * (b - a) + bary.y * (c - a);
      const glm::vec3 n = glm::normalize(glm::cross(b - a, c - a));
      const std::optional<size_t> cell = injectionCell(o, glm::dvec3(p), glm::dvec3(n));
      if (!cell) continue;
      Point& out = found[k];
      out.cell = *cell;
      const Frame frame = Frame::fromNormal(n);
      for (int r = 0; r < rays; ++r) {
        const glm::vec3 w = frame.toWorld(sampleCosineHemisphere(rng.uniform(), rng.uniform()));
        Ray ray;
        ray.origin = p + n * float(lift_);
        ray.dir = w;
        ray.tmin = 0.0f;
        ray.tmax = std::numeric_limits<float>::max();
        const Hit hit = engine_.intersect(ray);
        glm::dvec3 radiance(scene.environment);
        if (hit.hit()) {
          const size_t t = size_t(hit.triangle);
          const glm::uvec3 h = flat_.triangles[t];
          const glm::vec3 hn = glm::cross(flat_.positions[h.y] - flat_.positions[h.x],
                                          flat_.positions[h.z] - flat_.positions[h.x]);
          const Material& m = scene.materials[flat_.material_ids[t]];
          radiance = glm::dot(hn, w) < 0.0f ? glm::dvec3(m.emission) : glm::dvec3(0.0);
        }
        if (radiance == glm::dvec3(0.0)) continue;
        // Eq. 1 for the direction sample: T Phi (1 / pi) max(0, w_t . w).
        const double cos_i = std::max(0.0f, glm::dot(w, n));
        const glm::dvec3 d(-w);
        const glm::dvec4 lobe = lpvCosineLobe(refractInto(d, glm::dvec3(n), eta)) *
                                (fresnelTransmittance(eta, cos_i) * share / std::numbers::pi);
        for (int ch = 0; ch < 3; ++ch) out.c[ch] += lobe * radiance[ch];
      }
    }
  });
  for (const Point& pt : found) {
    if (pt.cell == std::numeric_limits<size_t>::max()) continue;
    for (int ch = 0; ch < 3; ++ch) o.surroundings.c[size_t(ch)][pt.cell] += glm::vec4(pt.c[ch]);
  }
}

}  // namespace penumbra
