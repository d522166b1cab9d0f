#include "penumbra/radiosity/radiosity_surface.h"

#include "penumbra/radiosity/texel_footprint.h"

#include "penumbra/core/check.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/core/parallel.h"
#include "penumbra/geometry/shading_normals.h"
#include "penumbra/geometry/tangents.h"
#include "penumbra/kernels/sampling.h"
#include "penumbra/raytrace/cutout_filter.h"
#include "penumbra/raytrace/lights.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <numbers>

namespace penumbra {

double texelDensityFor(const Scene& scene, uint32_t elements) {
  const double area = faceArea(scene);
  return area > 0.0 ? std::sqrt(double(elements) / area) : 0.0;
}

double normalMapTexelDensity(const Scene& scene) {
  // Per mapped triangle: sqrt(its UV area x the map's W x H / its area), area-weighted.
  double weighted = 0.0, area = 0.0;
  for (const Mesh& m : scene.meshes) {
    if (m.uvs.empty()) continue;
    for (size_t t = 0; t < m.triangles.size(); ++t) {
      const Material& mat = scene.materials[m.material_ids[t]];
      if (!mat.normal_map) continue;
      const glm::uvec3 tri = m.triangles[t];
      const double a =
          0.5 * glm::length(glm::cross(glm::dvec3(m.positions[tri.y] - m.positions[tri.x]),
                                       glm::dvec3(m.positions[tri.z] - m.positions[tri.x])));
      const glm::dvec2 d1(m.uvs[tri.y] - m.uvs[tri.x]), d2(m.uvs[tri.z] - m.uvs[tri.x]);
      const double uv_area = 0.5 * std::abs(d1.x * d2.y - d2.x * d1.y);
      if (!(a > 0.0) || !(uv_area > 0.0)) continue;
      const double texels = uv_area * mat.normal_map->width * mat.normal_map->height;
      weighted += std::sqrt(texels / a) * a;
      area += a;
    }
  }
  return area > 0.0 ? weighted / area : 0.0;
}

namespace {

// The automatic texel density for `elements`, raised towards the normal maps' own density
// (Wallner sec. 3.3 warns that a lightmap coarser than its normal map loses the map's detail)
// by at most a factor of 2 (4 times the elements).
double automaticDensity(const Scene& scene, uint32_t elements) {
  const double density = texelDensityFor(scene, elements);
  const double maps = normalMapTexelDensity(scene);
  return maps > density ? std::min(maps, 2.0 * density) : density;
}

}  // namespace

std::optional<AssetLightmapUvs> assetLightmapUvs(const Scene& scene) {
  AssetLightmapUvs a;
  uint32_t first = 0;
  for (const Mesh& m : scene.meshes) {
    const std::vector<glm::vec2>& uv = m.uvSet(1);
    const bool has = !uv.empty() && uv.size() == m.positions.size();
    const int32_t block = has ? int32_t(a.block_name.size()) : -1;
    if (has) {
      a.block_name.push_back(m.name.empty() ? scene.source : m.name);
      a.block_first.push_back(first);
    }
    for (const glm::uvec3& t : m.triangles) {
      a.block.push_back(block);
      for (int k = 0; k < 3; ++k) a.corner_uv.push_back(has ? uv[t[k]] : glm::vec2(0.0f));
    }
    first += uint32_t(m.triangles.size());
  }
  if (a.block_name.empty()) return std::nullopt;
  return a;
}

Expected<ChartAtlasOptions> lightmapAtlasOptions(const Scene& scene, const LightmapResolution& r) {
  ChartAtlasOptions o;
  o.asset_uvs = r.asset_uvs;
  if (r.texel_density) {
    if (!(*r.texel_density > 0.0 && std::isfinite(*r.texel_density))) {
      return inputError("", "--texel-density", "must be a positive number of texels per metre");
    }
    o.texel_density = *r.texel_density;
  } else if (r.size) {
    o.texel_density = 0.0;
    o.resolution = *r.size;
  } else {
    if (r.elements == 0) return inputError("", "--elements", "must be at least 1");
    o.texel_density = automaticDensity(scene, r.elements);
    if (!(o.texel_density > 0.0)) {
      return inputError(scene.source, "", "the scene has no surface area");
    }
  }
  return o;
}

uint64_t expectedLightmapElements(const Scene& scene, const LightmapResolution& r) {
  if (r.texel_density) {
    const double n = faceArea(scene) * *r.texel_density * *r.texel_density;
    return std::isfinite(n) && n < 1e18 ? uint64_t(n) : uint64_t(1e18);
  }
  if (r.size) return uint64_t(*r.size) * uint64_t(*r.size) / 2;
  const double plain = texelDensityFor(scene, r.elements);
  const double raised = plain > 0.0 ? automaticDensity(scene, r.elements) / plain : 1.0;
  return uint64_t(double(r.elements) * raised * raised);
}

Expected<RadiositySurface> RadiositySurface::build(const Scene& scene,
                                                   const ChartAtlasOptions& atlas_options,
                                                   bool shading_normals) {
  RadiositySurface s;
  s.flat = flattenScene(scene);
  const std::vector<SurfaceFace> faces = surfaceFaces(scene, s.flat);
  const std::optional<AssetLightmapUvs> asset =
      atlas_options.asset_uvs ? assetLightmapUvs(scene) : std::nullopt;
  Expected<ChartAtlas> atlas =
      buildChartAtlas(s.flat.positions, s.flat.triangles, s.flat.material_ids, faces, atlas_options,
                      asset ? &*asset : nullptr);
  if (!atlas.ok()) {
    Error e = atlas.error();
    if (e.file.empty()) e.file = scene.source;  // "cornell: --lightmap-size: ... do not fit"
    return e;
  }
  s.atlas = std::move(*atlas);
  // Every chart needs a texel: the hierarchy roots each chart in a cluster. A density far too
  // coarse for the scene (--texel-density 3e-4 on the Cornell box) leaves charts without one.
  std::vector<uint8_t> has_texel(s.atlas.chartCount(), 0);
  for (uint32_t c : s.atlas.element_chart) has_texel[c] = 1;
  if (const auto it = std::find(has_texel.begin(), has_texel.end(), 0); it != has_texel.end()) {
    return inputError(
        scene.source, "lightmap",
        fmt::format("{:g} texels per metre leave chart {} of {} without a texel: "
                    "the lightmap is too coarse for the scene (raise "
                    "--texel-density or --elements)",
                    s.atlas.texel_density, it - has_texel.begin(), s.atlas.chartCount()));
  }
  s.engine = RayEngine::build(s.flat.positions, s.flat.triangles);
  if (anyGlazing(scene.openings)) s.glazing = scene.openings;
  {
    auto textures = std::make_shared<const SurfaceTextures>(scene);
    if (textures->any() || textures->hasCutouts()) {
      s.textures = std::move(textures);
      s.engine.setHitFilter(cutoutFilter(s.textures));
    }
  }
  s.bounds = s.engine.bounds();
  s.lift = 1e-5 * double(glm::length(s.bounds.hi - s.bounds.lo));
  // The textures' means per element, and the points of texels a cut-out covers in part.
  if (s.textures) s.integrateTextures();
  // Each element's point on the side of its footprint that geometry standing on the chart does
  // not cut off (radiosity/texel_footprint.h), before anything reads the points.
  s.anchored = anchorElements(s);
  s.hierarchy = SurfaceHierarchy::build(s.atlas);
  s.has_side.assign(2 * s.flat.triangles.size(), 0);
  s.side_face.assign(2 * s.flat.triangles.size(), -1);
  for (size_t f = 0; f < s.atlas.faces.size(); ++f) {
    if (s.atlas.charts.face_chart[f] < 0) continue;
    const SurfaceFace& face = s.atlas.faces[f];
    s.has_side[2 * size_t(face.triangle) + (face.back ? 1 : 0)] = 1;
    s.side_face[2 * size_t(face.triangle) + (face.back ? 1 : 0)] = int32_t(f);
  }

  const size_t n = s.atlas.elementCount();
  s.material.resize(n);
  s.shading_normal.resize(n);
  const std::vector<glm::vec3> corner_normals =
      shading_normals ? cornerShadingNormals(scene) : std::vector<glm::vec3>();
  for (size_t e = 0; e < n; ++e) {
    // Every face of a chart has the chart's material.
    const uint32_t f = s.atlas.element_faces[s.atlas.element_face_first[e]];
    s.material[e] = s.flat.material_ids[s.atlas.faces[f].triangle];
    const glm::dvec3 ng = s.atlas.element_normal[e];
    s.shading_normal[e] = ng;
    if (!corner_normals.empty()) {
      // The corners' shading normals interpolated at the element's point on its face (Wallner
      // sec. 3); a back face takes them reversed.
      const uint32_t tf = s.atlas.element_face[e];
      const uint32_t t = s.atlas.faces[size_t(tf)].triangle;
      const glm::vec2 w = clampBarycentric(s.atlas.element_barycentric[e]);
      glm::dvec3 sn = (1.0 - double(w.x) - double(w.y)) * glm::dvec3(corner_normals[3 * t]) +
                      double(w.x) * glm::dvec3(corner_normals[3 * t + 1]) +
                      double(w.y) * glm::dvec3(corner_normals[3 * t + 2]);
      if (s.atlas.faces[size_t(tf)].back) sn = -sn;
      const double len = glm::length(sn);
      if (len > 0.0 && glm::dot(sn, ng) > 0.0) s.shading_normal[e] = sn / len;
    }
    s.total_area += s.atlas.element_area[e];
  }
  // Normal maps apply with or without interpolated normals (the GPU solver's faces' normals).
  if (shading_normals) {
    s.applyNormalMaps(scene, corner_normals);
  } else {
    std::vector<glm::vec3> face_normals(3 * s.flat.triangles.size());
    for (size_t t = 0; t < s.flat.triangles.size(); ++t) {
      const glm::uvec3 tri = s.flat.triangles[t];
      const glm::vec3 fn = glm::cross(s.flat.positions[tri.y] - s.flat.positions[tri.x],
                                      s.flat.positions[tri.z] - s.flat.positions[tri.x]);
      const float len = glm::length(fn);
      for (int k = 0; k < 3; ++k) face_normals[3 * t + size_t(k)] = len > 0.0f ? fn / len : fn;
    }
    s.applyNormalMaps(scene, face_normals);
  }
  s.applyMaterials(scene.materials);
  std::vector<uint8_t> known(s.atlas.texel_kind.size(), 0);
  for (size_t e = 0; e < s.elementCount(); ++e) known[s.atlas.element_texel[e]] = 1;
  s.gap_plan = planChartGaps(s.atlas, std::move(known));
  return s;
}

void RadiositySurface::applyNormalMaps(const Scene& scene,
                                       std::span<const glm::vec3> corner_normals) {
  bool any = false;
  for (const Material& m : scene.materials) any |= m.normal_map != nullptr;
  if (!any) return;
  // Wallner sec. 3.3: the receiver's cosine takes the normal the map gives at the element's
  // point, in the tangent frame of its triangle's corners (geometry/tangents.h).
  bool has_uvs = false;
  const std::vector<glm::vec2> uvs = flattenSceneUvs(scene, has_uvs);
  const std::vector<glm::vec4> tangents = cornerTangents(scene, corner_normals);
  std::vector<uint8_t> origin_top;
  std::vector<uint8_t> mesh_has_uvs;
  for (const Mesh& mesh : scene.meshes) {
    origin_top.insert(origin_top.end(), mesh.triangles.size(), mesh.uv_origin_top ? 1 : 0);
    mesh_has_uvs.insert(mesh_has_uvs.end(), mesh.triangles.size(), mesh.uvs.empty() ? 0 : 1);
  }
  for (size_t e = 0; e < elementCount(); ++e) {
    const Material& m = scene.materials[material[e]];
    if (!m.normal_map) continue;
    const uint32_t tf = atlas.element_face[e];
    if (atlas.faces[size_t(tf)].back) continue;  // the map is on the front of the surface
    const uint32_t t = atlas.faces[size_t(tf)].triangle;
    if (!mesh_has_uvs[t]) continue;
    const glm::vec2 w = clampBarycentric(atlas.element_barycentric[e]);
    const float w0 = 1.0f - w.x - w.y;
    const glm::vec2 uv = w0 * uvs[3 * t] + w.x * uvs[3 * t + 1] + w.y * uvs[3 * t + 2];
    const glm::vec4 tan =
        w0 * tangents[3 * t] + w.x * tangents[3 * t + 1] + w.y * tangents[3 * t + 2];
    glm::vec3 txyz(tan);
    const glm::dvec3 n = shading_normal[e];
    glm::dvec3 tt = glm::dvec3(txyz) - n * glm::dot(n, glm::dvec3(txyz));
    if (!(glm::length(tt) > 1e-9)) continue;
    tt = glm::normalize(tt);
    const glm::vec3 rgb = sampleNormalMap(*m.normal_map, uv, origin_top[t] != 0);
    const glm::dvec3 p =
        perturbedNormal(n, glm::vec4(glm::vec3(tt), tangents[3 * t].w), rgb, m.normal_scale);
    // A map may not turn the normal below the face: such a receiver would face away from what
    // lights it.
    if (glm::dot(p, atlas.element_normal[e]) > 1e-3) shading_normal[e] = p;
  }
}

void RadiositySurface::integrateTextures() {
  const size_t n = elementCount();
  texture_reflectance.assign(n, glm::dvec3(1.0));
  texture_emission.assign(n, glm::dvec3(1.0));
  if (textures->hasCutouts()) coverage.assign(n, 1.0);
  // Each element's pieces (its texel square clipped to each face it covers), in the faces'
  // barycentrics, and the texture means over them weighted by area.
  parallelRange(n, 256, [&](size_t begin, size_t end) {
    for (size_t e = begin; e < end; ++e) {
      const glm::ivec2 texel = atlas.texelOf(e);
      const glm::dvec2 lo(texel), hi(glm::dvec2(texel) + 1.0);
      const uint32_t first = atlas.element_face_first[e], last = atlas.element_face_first[e + 1];
      bool varies = false;
      for (uint32_t k = first; k < last; ++k) {
        const uint32_t t = atlas.faces[atlas.element_faces[k]].triangle;
        varies = varies || textures->varies(t) || textures->isCutout(t);
      }
      if (!varies) continue;
      // Every piece counts, those of plain faces with the factors alone (mean() gives 1).
      glm::dvec3 reflectance_sum(0.0), emission_sum(0.0);
      double coverage_sum = 0.0, area = 0.0;
      // The covered part's centre: summed over the pieces, and the piece that covers most.
      bool one_face = true;
      uint32_t best_face = 0;
      glm::dvec2 best_bary(0.0), bary_sum(0.0);
      double best = 0.0;
      for (uint32_t k = first; k < last; ++k) {
        const uint32_t f = atlas.element_faces[k];
        const uint32_t t = atlas.faces[f].triangle;
        const glm::dvec2 t0(atlas.corner_texel[3 * size_t(f)]),
            t1(atlas.corner_texel[3 * size_t(f) + 1]), t2(atlas.corner_texel[3 * size_t(f) + 2]);
        glm::dvec2 poly[8];
        const int count = clipTriangleToRect(t0, t1, t2, lo, hi, poly);
        if (count < 3) continue;
        const glm::dvec2 e1 = t1 - t0, e2 = t2 - t0;
        const double det = e1.x * e2.y - e1.y * e2.x;
        if (det == 0.0) continue;
        glm::vec2 bary[8];
        double piece_area = 0.0;
        for (int c = 0; c < count; ++c) {
          const glm::dvec2 d = poly[c] - t0;
          bary[c] = glm::vec2(float((d.x * e2.y - d.y * e2.x) / det),
                              float((e1.x * d.y - e1.y * d.x) / det));
        }
        for (int c = 1; c + 1 < count; ++c) {
          const glm::dvec2 a = poly[c] - poly[0], b = poly[c + 1] - poly[0];
          piece_area += 0.5 * std::abs(a.x * b.y - a.y * b.x);
        }
        const SurfaceTextures::Mean m =
            textures->mean(t, std::span<const glm::vec2>(bary, size_t(count)), false);
        reflectance_sum += piece_area * m.reflectance;
        emission_sum += piece_area * m.emission;
        coverage_sum += piece_area * m.coverage;
        area += piece_area;
        const double covered = piece_area * m.coverage;
        if (covered > 0.0) {
          bary_sum += covered * m.covered_centroid;
          if (best > 0.0 && f != best_face) one_face = false;
          if (covered > best) best = covered, best_face = f, best_bary = m.covered_centroid;
        }
      }
      if (area > 0.0) {
        texture_reflectance[e] = reflectance_sum / area;
        texture_emission[e] = emission_sum / area;
        if (!coverage.empty()) coverage[e] = coverage_sum / area;
      }
      // A texel a cut-out covers in part stands for its covered part: its point moves to that
      // part's centre (on the face that covers most when its pieces lie on several), where the
      // path-traced bake's samples are centred. At the centre of the whole texel a half-covered
      // lattice texel beside the ceiling panel read the irradiance 10 cm from where its bars are
      // (10-16% off the path-traced bake at 5 texels/m).
      const double covered_total = coverage_sum;
      if (!coverage.empty() && covered_total > 0.0 && covered_total < 0.999 * area) {
        const glm::dvec2 w = one_face ? bary_sum / covered_total : best_bary;
        const glm::uvec3 tri = flat.triangles[atlas.faces[best_face].triangle];
        const glm::dvec3 p0(flat.positions[tri.x]), p1(flat.positions[tri.y]),
            p2(flat.positions[tri.z]);
        atlas.element_position[e] = p0 + w.x * (p1 - p0) + w.y * (p2 - p0);
        atlas.element_face[e] = best_face;
        atlas.element_barycentric[e] = glm::vec2(w);
      }
    }
  });
}

void RadiositySurface::applyMaterials(std::span<const Material> materials) {
  const size_t n = elementCount();
  reflectance.resize(n);
  emission.resize(n);
  const bool textured = !texture_reflectance.empty();
  for (size_t e = 0; e < n; ++e) {
    const Material& m = materials[material[e]];
    const bool back = atlas.faces[atlas.element_face[e]].back;
    reflectance[e] = glm::dvec3(m.reflectance);
    // An unlit surface emits nothing into the solution (views show it, Material::unlit).
    emission[e] = back || m.unlit ? glm::dvec3(0.0) : std::numbers::pi * glm::dvec3(m.emission);
    if (textured) {
      reflectance[e] *= texture_reflectance[e];
      emission[e] *= texture_emission[e];
    }
  }
}

std::shared_ptr<const LightmapDetail> RadiositySurface::lightmapDetail() const {
  if (!textures) return nullptr;
  auto detail = std::make_shared<LightmapDetail>();
  detail->textures = textures;
  // Per texel: the mean reflectance (stored as radiance pi rho / pi) and the mean emitted
  // radiance (emission holds pi Le), gap-filled as the lightmap is.
  std::vector<glm::dvec3> rho(elementCount());
  for (size_t e = 0; e < rho.size(); ++e) rho[e] = std::numbers::pi * reflectance[e];
  detail->mean_reflectance = radianceImage(rho);
  detail->mean_emission = radianceImage(emission);
  return detail;
}

std::vector<glm::dvec3> RadiositySurface::lightIrradiance(std::span<const Light> lights,
                                                          bool visibility, uint64_t* rays) const {
  return lightIrradianceAt(lights, visibility, atlas.element_position, atlas.element_normal,
                           shading_normal, rays);
}

Ray RadiositySurface::shadowRayToLight(const LightSample& s, const glm::dvec3& p,
                                       const glm::dvec3& ng) const {
  // To the light's position, or far out for a directional one.
  const glm::dvec3 from = p + ng * lift;
  Ray ray{glm::vec3(from), 1e-4f, glm::vec3(s.direction * s.distance),
          s.distance > 1e30 ? std::numeric_limits<float>::max() : 1.0f - 1e-4f};
  if (s.distance > 1e30) ray.dir = glm::vec3(s.direction);
  return ray;
}

std::vector<glm::dvec3> RadiositySurface::lightIrradianceAt(
    std::span<const Light> lights, bool visibility, std::span<const glm::dvec3> positions,
    std::span<const glm::dvec3> normals, std::span<const glm::dvec3> shading_normals,
    uint64_t* rays) const {
  const size_t n = positions.size();
  PENUMBRA_CHECK(normals.size() == n && shading_normals.size() == n);
  std::vector<glm::dvec3> out(n, glm::dvec3(0.0));
  if (lights.empty()) return out;
  std::atomic<uint64_t> traced{0};
  // Every receiver against every light: with thousands of luminaires this one step takes
  // minutes, so a stop request ends it (core/interrupt.h: throwIfStoppedMidStep) rather than
  // waiting for it.
  std::atomic<bool> stopped{false};
  parallelRange(n, 1024, [&](size_t begin, size_t end) {
    uint64_t count = 0;
    for (size_t r = begin; r < end; ++r) {
      if (r % 64 == 0 && (stopped.load(std::memory_order_relaxed) || stoppedMidStep())) {
        stopped = true;
        return;
      }
      glm::dvec3 sum(0.0);
      for (const Light& light : lights) {
        const LightSample s = sampleLight(light, positions[r], normals[r], shading_normals[r]);
        if (s.irradiance == glm::dvec3(0.0)) continue;
        if (visibility) {
          ++count;
          if (engine.occluded(shadowRayToLight(s, positions[r], normals[r]))) continue;
        }
        sum += glazing.empty()
                   ? s.irradiance
                   : s.irradiance * transmittanceThrough(
                                        glazing, positions[r], s.direction,
                                        s.distance > 1e30 ? std::numeric_limits<double>::infinity()
                                                          : s.distance);
      }
      out[r] = sum;
    }
    traced += count;
  });
  if (stopped) throwIfStoppedMidStep();
  if (rays) *rays += traced.load();
  return out;
}

int32_t RadiositySurface::elementAtHit(int32_t t, float u, float v, const glm::vec3& dir) const {
  if (t < 0) return -1;
  const glm::uvec3 tri = flat.triangles[size_t(t)];
  const glm::vec3 ng = glm::cross(flat.positions[tri.y] - flat.positions[tri.x],
                                  flat.positions[tri.z] - flat.positions[tri.x]);
  const int32_t f = side_face[2 * size_t(t) + (glm::dot(ng, dir) > 0.0f ? 1 : 0)];
  if (f < 0) return -1;
  const glm::dvec2 at = atlas.corner_texel[3 * size_t(f)] * double(1.0f - u - v) +
                        atlas.corner_texel[3 * size_t(f) + 1] * double(u) +
                        atlas.corner_texel[3 * size_t(f) + 2] * double(v);
  const int x = std::clamp(int(std::floor(at.x)), 0, atlas.width - 1);
  const int y = std::clamp(int(std::floor(at.y)), 0, atlas.height - 1);
  const int32_t e = atlas.texel_element[atlas.texelIndex(x, y)];
  if (e >= 0) return e;
  // A border texel (the chart's edge crosses it without an element there): the nearest element
  // of the same chart around it.
  const int32_t chart = atlas.charts.face_chart[size_t(f)];
  int32_t best = -1;
  double best_d = std::numeric_limits<double>::infinity();
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      const int xx = x + dx, yy = y + dy;
      if (xx < 0 || yy < 0 || xx >= atlas.width || yy >= atlas.height) continue;
      const int32_t n = atlas.texel_element[atlas.texelIndex(xx, yy)];
      if (n < 0 || int32_t(atlas.element_chart[size_t(n)]) != chart) continue;
      const double d = glm::length(glm::dvec2(xx + 0.5, yy + 0.5) - at);
      if (d < best_d) best_d = d, best = n;
    }
  }
  return best;
}

bool RadiositySurface::allHitElements(const RayBatch& rays) const {
  HitBatch hits;
  engine.intersect(rays, hits);
  for (size_t i = 0; i < rays.size(); ++i) {
    const int32_t t = hits.triangle[i];
    if (t < 0) return false;  // escaped to the outside
    const glm::uvec3 tri = flat.triangles[size_t(t)];
    const glm::vec3 ng = glm::cross(flat.positions[tri.y] - flat.positions[tri.x],
                                    flat.positions[tri.z] - flat.positions[tri.x]);
    const glm::vec3 d(rays.dx[i], rays.dy[i], rays.dz[i]);
    const bool back = glm::dot(ng, d) > 0.0f;
    if (!has_side[2 * size_t(t) + (back ? 1 : 0)]) return false;  // a black back face
  }
  return true;
}

bool RadiositySurface::seesOnlyElements(uint32_t first, uint32_t last, int count,
                                        uint64_t seed) const {
  if (count <= 0 || last <= first) return false;
  std::vector<double> cdf;
  cdf.reserve(last - first);
  double sum = 0.0;
  for (uint32_t e = first; e < last; ++e) {
    sum += atlas.element_area[e];
    cdf.push_back(sum);
  }
  if (!(sum > 0.0)) return false;
  Rng rng(0x5eedu, seed);
  RayBatch rays;
  rays.resize(size_t(count));
  for (int i = 0; i < count; ++i) {
    const double u = double(rng.uniform()) * cdf.back();
    const uint32_t e =
        first +
        uint32_t(std::min<size_t>(size_t(std::upper_bound(cdf.begin(), cdf.end(), u) - cdf.begin()),
                                  cdf.size() - 1));
    const glm::vec3 nrm(atlas.element_normal[e]);
    const glm::vec3 d =
        Frame::fromNormal(nrm).toWorld(sampleCosineHemisphere(rng.uniform(), rng.uniform()));
    Ray ray;
    ray.origin = glm::vec3(atlas.element_position[e] + atlas.element_normal[e] * lift);
    ray.dir = d;
    ray.tmin = 0.0f;
    ray.tmax = std::numeric_limits<float>::max();
    rays.set(size_t(i), ray);
  }
  return allHitElements(rays);
}

namespace {

template <typename Vec>
Image radianceImageOf(const RadiositySurface& s, std::span<const Vec> radiosity) {
  PENUMBRA_CHECK(radiosity.size() == s.elementCount());
  Image img(s.atlas.width, s.atlas.height);
  for (size_t e = 0; e < s.elementCount(); ++e) {
    img.pixels[s.atlas.element_texel[e]] = glm::vec3(glm::dvec3(radiosity[e]) / std::numbers::pi);
  }
  applyChartGaps(s.gap_plan, img);
  return img;
}

}  // namespace

Image RadiositySurface::radianceImage(std::span<const glm::dvec3> radiosity) const {
  return radianceImageOf(*this, radiosity);
}

Image RadiositySurface::radianceImage(std::span<const glm::vec3> radiosity) const {
  return radianceImageOf(*this, radiosity);
}

}  // namespace penumbra
