#include "penumbra/subsurface/lpv.h"

#include "penumbra/core/memory.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/core/timer.h"
#include "penumbra/kernels/dipole.h"
#include "penumbra/raytrace/camera_rays.h"
#include "penumbra/raytrace/cutout_filter.h"
#include "penumbra/raytrace/lights.h"
#include "penumbra/subsurface/lpv_gl.h"
#include "penumbra/subsurface/lpv_sh.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <numbers>
#include <variant>

namespace penumbra {

namespace {

// Bytes per cell: the surroundings', injected, propagation (two) and accumulation fields (3
// channels x 16 bytes each), the propagation step's scratch, the medium (28) and the cell's kind.
constexpr uint64_t kBytesPerCell = 6 * 48 + 28 + 1;

}  // namespace

Expected<LpvSolver> LpvSolver::build(const Scene& scene, const LpvOptions& options) {
  if (options.grid < 4 || options.grid > kLpvMaxGrid) {
    return inputError("", "--grid", fmt::format("must be in [4, {}]", kLpvMaxGrid));
  }
  if (options.steps < 1 || options.steps > 4096) {
    return inputError("", "--steps", "must be in [1, 4096]");
  }
  if (options.skip_steps < 0 || options.skip_steps >= options.steps) {
    return inputError("", "--skip-steps", "must be at least 0 and below --steps");
  }
  if (options.rsm_resolution < 1 || options.rsm_resolution > 4096) {
    return inputError("", "--rsm-resolution", "must be in [1, 4096]");
  }
  if (options.surface_samples < 0 || options.surface_samples > kLpvMaxSurfaceSamples) {
    return inputError("", "--surface-samples",
                      fmt::format("must be in [0, {}]", kLpvMaxSurfaceSamples));
  }
  if (options.surface_rays < 0 || options.surface_rays > 256) {
    return inputError("", "--surface-rays", "must be in [0, 256]");
  }
  LpvSolver s;
  s.options_ = options;
  uint64_t cells = 0;
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    const Mesh& mesh = scene.meshes[m];
    // One volume per mesh with a translucent material (its first such material's medium).
    for (uint32_t id : mesh.material_ids) {
      if (!scene.materials[id].subsurface) continue;
      LpvObject o;
      o.mesh = uint32_t(m);
      o.material = id;
      o.medium = *scene.materials[id].subsurface;
      o.grid = LpvGrid::around(Bounds3::of(mesh.positions), options.grid);
      // Any shape the mesh takes later: at most grid^3 cells.
      cells += uint64_t(options.grid) * uint64_t(options.grid) * uint64_t(options.grid);
      s.objects_.push_back(std::move(o));
      break;
    }
  }
  if (s.objects_.empty()) {
    return inputError(scene.source, "",
                      "no translucent material (a `subsurface` block) for --method lpv");
  }
  PENUMBRA_TRY(checkMemory(cells * kBytesPerCell,
                           fmt::format("light propagation volumes of {} cells", cells)));
  return s;
}

uint64_t LpvSolver::gridBytes() const {
  uint64_t cells = 0;
  for (const LpvObject& o : objects_) cells += o.grid.cellCount();
  return cells * kBytesPerCell;
}

Status LpvSolver::useGpu() {
  Expected<GlLpv> gl = GlLpv::create();
  if (!gl) return gl.error();
  gpu_ = std::make_shared<GlLpv>(std::move(*gl));
  // The volumes go up with the next update.
  stale_ = true;
  return {};
}

Expected<LpvFrameTimes> LpvSolver::update(const Scene& scene) {
  LpvFrameTimes times;
  // Voxelisation, and the geometry as it is now for the maps and the view.
  Timer timer;
  FlatTriangles flat = flattenScene(scene);
  const bool same = geometry_ > 0 && !stale_ && flat.positions == flat_.positions &&
                    flat.triangles == flat_.triangles && flat.material_ids == flat_.material_ids;
  if (!same) PENUMBRA_TRY(rebuild(scene, std::move(flat)));
  times.voxelise = timer.seconds();

  timer = Timer();
  std::vector<glm::vec3> emissions;
  for (const Material& m : scene.materials) emissions.push_back(m.emission);
  if (!same || emissions != emissions_ || scene.environment != environment_) {
    emissions_ = std::move(emissions);
    environment_ = scene.environment;
    for (size_t k = 0; k < objects_.size(); ++k) {
      injectSurroundings(scene, objects_[k], uint32_t(k));
    }
  }
  for (size_t k = 0; k < objects_.size(); ++k) {
    inject(scene, objects_[k], uint32_t(k), &times.rsm_texels);
  }
  times.inject = timer.seconds();

  timer = Timer();
  PENUMBRA_TRY(propagate());
  times.propagate = timer.seconds();
  return times;
}

Status LpvSolver::rebuild(const Scene& scene, FlatTriangles flat) {
  ++geometry_;
  stale_ = false;
  flat_ = std::move(flat);
  engine_ = RayEngine::build(flat_.positions, flat_.triangles);
  engine_.setHitFilter(sceneCutouts(scene));  // light reaches the medium through cut-outs
  Bounds3 bounds;
  for (const glm::vec3& p : flat_.positions) bounds.extend(p);
  lift_ = 1e-5 * double(glm::length(bounds.hi - bounds.lo));
  triangle_object_.assign(flat_.triangles.size(), 0);
  std::vector<size_t> first(scene.meshes.size() + 1, 0);
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    first[m + 1] = first[m] + scene.meshes[m].triangles.size();
  }
  for (size_t k = 0; k < objects_.size(); ++k) {
    LpvObject& o = objects_[k];
    const Mesh& mesh = scene.meshes[o.mesh];
    for (size_t t = first[o.mesh]; t < first[o.mesh + 1]; ++t) {
      if (flat_.material_ids[t] == o.material) triangle_object_[t] = uint32_t(k + 1);
    }
    // The grid follows the mesh (the same resolution along its longest side).
    o.grid = LpvGrid::around(Bounds3::of(mesh.positions), options_.grid);
    o.cells = lpvVoxelise(o.grid, mesh.positions, mesh.triangles);
    o.cell_medium = lpvMedium(o.grid, o.medium, Bounds3::of(mesh.positions));
    o.transfer = lpvTransfer(o.grid, o.cells, o.cell_medium);
    const size_t n = o.grid.cellCount();
    o.injected.resize(n);
    o.accumulated.resize(n);
    // The CPU's propagation fields; the GPU keeps its own.
    for (LpvField* f : {&o.propagation[0], &o.propagation[1], &o.sent}) {
      if (gpu_) {
        *f = LpvField{};
      } else {
        f->resize(n);
      }
    }
    if (gpu_) PENUMBRA_TRY(gpu_->setVolume(k, o.grid, o.cells, o.transfer));
  }
  return {};
}

Status LpvSolver::propagate() {
  if (gpu_) {
    for (size_t k = 0; k < objects_.size(); ++k) {
      LpvObject& o = objects_[k];
      PENUMBRA_TRY(
          gpu_->propagate(k, o.injected, options_.steps, options_.skip_steps, o.accumulated));
    }
    return {};
  }
  for (LpvObject& o : objects_) {
    const std::vector<uint32_t>& cells = o.transfer.cells;
    LpvField* a = &o.propagation[0];
    LpvField* b = &o.propagation[1];
    // The fields are zero outside the object's cells; only those change.
    parallelRange(cells.size(), 4096, [&](size_t b0, size_t b1) {
      for (size_t k = b0; k < b1; ++k) {
        const size_t i = cells[k];
        for (size_t ch = 0; ch < 3; ++ch) {
          a->c[ch][i] = o.injected.c[ch][i];
          o.accumulated.c[ch][i] = glm::vec4(0.0f);
        }
      }
    });
    for (int step = 1; step <= options_.steps; ++step) {
      lpvPropagate(o.grid, o.transfer, *a, *b, o.sent);
      std::swap(a, b);
      if (step <= options_.skip_steps) continue;
      parallelRange(cells.size(), 4096, [&](size_t b0, size_t b1) {
        for (size_t k = b0; k < b1; ++k) {
          const size_t i = cells[k];
          for (size_t ch = 0; ch < 3; ++ch) o.accumulated.c[ch][i] += a->c[ch][i];
        }
      });
    }
  }
  return {};
}

glm::dvec3 LpvSolver::incidentRadiance(size_t k, const glm::dvec3& p, const glm::dvec3& n) const {
  const LpvObject& o = objects_[k];
  // The accumulated coefficients at p, trilinear over the eight nearest cell centres that belong
  // to the object (weights renormalised; the paper takes the one cell holding p, which shows
  // the cells as blocks); the cell holding p when none of the eight does.
  const glm::dvec3 f = (p - o.grid.origin) / o.grid.cell - 0.5;
  const glm::ivec3 base(glm::floor(f));
  const glm::dvec3 t = f - glm::dvec3(base);
  glm::dvec4 c[3] = {glm::dvec4(0.0), glm::dvec4(0.0), glm::dvec4(0.0)};
  double weight = 0.0;
  for (int corner = 0; corner < 8; ++corner) {
    const glm::ivec3 offset(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
    const glm::ivec3 cell = base + offset;
    if (!o.grid.contains(cell)) continue;
    const size_t i = o.grid.index(cell);
    if (o.cells[i] == LpvCell::kOutside) continue;
    const double w =
        (offset.x ? t.x : 1.0 - t.x) * (offset.y ? t.y : 1.0 - t.y) * (offset.z ? t.z : 1.0 - t.z);
    for (int ch = 0; ch < 3; ++ch) c[ch] += w * glm::dvec4(o.accumulated.c[size_t(ch)][i]);
    weight += w;
  }
  if (!(weight > 0.0)) {
    const size_t i = o.grid.index(o.grid.cellOf(p - n * (0.5 * o.grid.cell)));
    for (int ch = 0; ch < 3; ++ch) c[ch] = glm::dvec4(o.accumulated.c[size_t(ch)][i]);
    weight = 1.0;
  }
  const double area = o.grid.cell * o.grid.cell;
  glm::dvec3 l(0.0);
  for (int ch = 0; ch < 3; ++ch) {
    l[ch] = std::max(0.0, lpvAreaLightRadiance(c[ch] / weight, n, area));
  }
  return l;
}

Image LpvSolver::render(const Scene& scene, const Camera& camera, int width, int height, int spp,
                        uint64_t seed, LpvFrameTimes* times) {
  const Timer timer;
  spp = std::max(spp, 1);
  const bool cached = view_.valid && view_.geometry == geometry_ && view_.width == width &&
                      view_.height == height && view_.spp == spp && view_.seed == seed &&
                      view_.camera.position == camera.position &&
                      view_.camera.look_at == camera.look_at && view_.camera.up == camera.up &&
                      view_.camera.vertical_fov == camera.vertical_fov;
  if (!cached) {
    view_ = ViewCache{};
    const CameraRays rays(camera, width, height);
    const float w = 1.0f / float(spp);
    view_.emitted.assign(size_t(width) * size_t(height), glm::vec3(0.0f));
    // Rows in parallel, each with its own list, joined in row order.
    std::vector<std::vector<ViewSample>> rows(static_cast<size_t>(height));
    parallelRange(size_t(height), 1, [&](size_t y0, size_t y1) {
      for (size_t y = y0; y < y1; ++y) {
        for (int x = 0; x < width; ++x) {
          const uint32_t pixel = uint32_t(y * size_t(width) + size_t(x));
          for (int k = 0; k < spp; ++k) {
            const glm::vec2 j = pixelJitter(seed, pixel, uint32_t(k), spp);
            const Ray ray = rays.ray(float(x) + j.x, float(y) + j.y);
            const Hit hit = engine_.intersect(ray);
            if (!hit.hit()) {
              view_.emitted[pixel] += scene.environment * w;
              continue;
            }
            const size_t t = size_t(hit.triangle);
            const glm::uvec3 tri = flat_.triangles[t];
            const glm::vec3 n =
                glm::normalize(glm::cross(flat_.positions[tri.y] - flat_.positions[tri.x],
                                          flat_.positions[tri.z] - flat_.positions[tri.x]));
            const bool back = glm::dot(ray.dir, n) >= 0.0f;
            const Material& m = scene.materials[flat_.material_ids[t]];
            const glm::vec3 p = ray.origin + hit.t * ray.dir;
            const uint32_t object = triangle_object_[t];
            if (object != 0) {
              if (back) continue;  // inside the object: black
              // Sec. 3.3: T(w_o) L_i, L_i looked up at each frame.
              const double cos_o = std::max(0.0f, -glm::dot(ray.dir, n));
              const float ft = float(fresnelTransmittance(m.subsurface->eta, cos_o));
              rows[y].push_back({pixel, object, p, n, glm::vec3(ft * w)});
              continue;
            }
            if (!back && m.isEmissive()) view_.emitted[pixel] += m.emission * w;
            if ((back && !m.two_sided) || m.reflectance == glm::vec3(0.0f)) continue;
            rows[y].push_back({pixel, 0, p, back ? -n : n, m.reflectance * w});
          }
        }
      }
    });
    for (const std::vector<ViewSample>& r : rows) {
      view_.samples.insert(view_.samples.end(), r.begin(), r.end());
    }
    view_.valid = true;
    view_.geometry = geometry_;
    view_.camera = camera;
    view_.width = width;
    view_.height = height;
    view_.spp = spp;
    view_.seed = seed;
  }
  Image image(width, height);
  image.pixels = view_.emitted;
  // Samples are in pixel order; each thread takes whole rows, so no pixel is written by two.
  parallelRange(size_t(height), 4, [&](size_t y0, size_t y1) {
    const uint32_t first = uint32_t(y0 * size_t(width)), last = uint32_t(y1 * size_t(width));
    auto it = std::lower_bound(view_.samples.begin(), view_.samples.end(), first,
                               [](const ViewSample& v, uint32_t p) { return v.pixel < p; });
    for (; it != view_.samples.end() && it->pixel < last; ++it) {
      const glm::dvec3 p(it->point), n(it->normal);
      const glm::dvec3 l = it->object != 0 ? incidentRadiance(it->object - 1, p, n)
                                           : visibleIrradiance(engine_, lift_, scene.lights, p, n) /
                                                 std::numbers::pi;
      image.pixels[it->pixel] += it->factor * glm::vec3(l);
    }
  });
  if (times) times->shade += timer.seconds();
  return image;
}

}  // namespace penumbra
