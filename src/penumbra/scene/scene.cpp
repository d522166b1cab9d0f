#include "penumbra/scene/scene.h"

#include "penumbra/scene/coplanar_emitters.h"
#include "penumbra/scene/media.h"

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <fmt/format.h>
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace penumbra {

size_t Scene::triangleCount() const {
  size_t n = 0;
  for (const Mesh& m : meshes) n += m.triangles.size();
  return n;
}

size_t Scene::vertexCount() const {
  size_t n = 0;
  for (const Mesh& m : meshes) n += m.positions.size();
  return n;
}

void Scene::append(Scene other) {
  const uint32_t base = static_cast<uint32_t>(materials.size());
  for (Material& m : other.materials) materials.push_back(std::move(m));
  for (Mesh& mesh : other.meshes) {
    for (uint32_t& id : mesh.material_ids) id += base;
    meshes.push_back(std::move(mesh));
  }
  for (Light& l : other.lights) lights.push_back(l);
  for (CalculationGrid& g : other.calculation) calculation.push_back(std::move(g));
  for (Opening& o : other.openings) openings.push_back(std::move(o));
  if (!sky && other.sky) sky = other.sky;
  for (std::string& w : other.warnings) warnings.push_back(std::move(w));
  if (!camera && other.camera) camera = other.camera;
  environment = glm::max(environment, other.environment);
}

FlatTriangles flattenScene(const Scene& scene) {
  FlatTriangles f;
  f.positions.reserve(scene.vertexCount());
  f.triangles.reserve(scene.triangleCount());
  f.material_ids.reserve(scene.triangleCount());
  for (const Mesh& mesh : scene.meshes) {
    const uint32_t base = uint32_t(f.positions.size());
    f.positions.insert(f.positions.end(), mesh.positions.begin(), mesh.positions.end());
    for (const glm::uvec3& t : mesh.triangles) f.triangles.push_back(t + glm::uvec3(base));
    f.material_ids.insert(f.material_ids.end(), mesh.material_ids.begin(), mesh.material_ids.end());
  }
  return f;
}

double surfaceArea(const FlatTriangles& flat) {
  double area = 0.0;
  for (const glm::uvec3& t : flat.triangles) {
    area += 0.5 * glm::length(glm::cross(glm::dvec3(flat.positions[t.y] - flat.positions[t.x]),
                                         glm::dvec3(flat.positions[t.z] - flat.positions[t.x])));
  }
  return area;
}

std::vector<glm::vec2> flattenSceneUvs(const Scene& scene, bool& any) {
  std::vector<glm::vec2> uvs;
  uvs.reserve(3 * scene.triangleCount());
  any = false;
  for (const Mesh& mesh : scene.meshes) {
    const bool has = !mesh.uvs.empty();
    any = any || has;
    for (const glm::uvec3& tri : mesh.triangles) {
      for (int k = 0; k < 3; ++k) uvs.push_back(has ? mesh.uvs[tri[k]] : glm::vec2(0.0f));
    }
  }
  return uvs;
}

namespace {

bool finite3(const glm::vec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

std::string meshPlace(const Mesh& mesh, size_t mesh_index) {
  return mesh.name.empty() ? fmt::format("mesh {}", mesh_index)
                           : fmt::format("mesh {} ('{}')", mesh_index, mesh.name);
}

}  // namespace

namespace {

// The box around every mesh vertex (lo > hi when there is none).
std::pair<glm::vec3, glm::vec3> vertexBounds(const Scene& scene) {
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
  for (const Mesh& m : scene.meshes) {
    for (const glm::vec3& p : m.positions) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
  }
  return {lo, hi};
}

}  // namespace

glm::vec3 sceneCentre(const Scene& scene) {
  const auto [lo, hi] = vertexBounds(scene);
  return lo.x <= hi.x ? 0.5f * (lo + hi) : glm::vec3(0.0f);
}

std::vector<Light> orbitLights(std::span<const Light> lights, const glm::vec3& centre,
                               float angle) {
  const float c = std::cos(angle), s = std::sin(angle);
  const auto turn = [&](const glm::vec3& v) {
    return glm::vec3(c * v.x + s * v.z, v.y, -s * v.x + c * v.z);
  };
  std::vector<Light> out;
  for (const Light& light : lights) {
    Light l = light;
    std::visit(Overloaded{[&](PointLight& p) { p.position = centre + turn(p.position - centre); },
                          [&](SpotLight& sp) {
                            sp.position = centre + turn(sp.position - centre);
                            sp.direction = turn(sp.direction);
                          },
                          [&](DirectionalLight& d) { d.direction = turn(d.direction); },
                          [&](LuminaireLight& lu) {
                            lu.position = centre + turn(lu.position - centre);
                            lu.nadir = turn(lu.nadir);
                            lu.c0 = turn(lu.c0);
                          }},
               l);
    out.push_back(l);
  }
  return out;
}

namespace {

// A material's coverage and texture slots (scene/material.h).
Status checkCoverage(const Scene& scene, const Material& m, const std::string& place) {
  if (!(m.alpha >= 0.0f && m.alpha <= 1.0f)) {
    return inputError(scene.source, place, fmt::format("alpha {} is outside [0, 1]", m.alpha));
  }
  // glTF 2.0 gives alphaCutoff a minimum of 0 and no maximum: above 1 nothing is covered.
  if (!(m.alpha_cutoff >= 0.0f && std::isfinite(m.alpha_cutoff))) {
    return inputError(scene.source, place,
                      fmt::format("alpha cutoff {} is not a finite number >= 0", m.alpha_cutoff));
  }
  for (const auto* binding : {&m.reflectance_texture, &m.emission_texture, &m.coverage_texture}) {
    if (!*binding) continue;
    const TextureBinding& b = **binding;
    if (!b.texture) return inputError(scene.source, place, "a texture slot has no image");
    if (!finite3(b.row_u) || !finite3(b.row_v)) {
      return inputError(
          scene.source, place,
          fmt::format("the texture transform of '{}' is not finite", b.texture->source()));
    }
  }
  return {};
}

// The UV sets and vertex colours of a mesh: one per vertex, finite, colours in [0, 1].
Status checkMeshAttributes(const Scene& scene, const Mesh& mesh, const std::string& where) {
  for (size_t set = 0; set <= mesh.extra_uvs.size(); ++set) {
    const std::vector<glm::vec2>& uvs = mesh.uvSet(uint32_t(set));
    if (!uvs.empty() && uvs.size() != mesh.positions.size()) {
      return inputError(scene.source, where,
                        fmt::format("UV set {} has {} texture coordinates for {} vertices", set,
                                    uvs.size(), mesh.positions.size()));
    }
    for (size_t i = 0; i < uvs.size(); ++i) {
      if (!std::isfinite(uvs[i].x) || !std::isfinite(uvs[i].y)) {
        return inputError(scene.source,
                          fmt::format("{}, texture coordinate {} of UV set {}", where, i, set),
                          "not a finite number");
      }
    }
  }
  if (!mesh.colors.empty() && mesh.colors.size() != mesh.positions.size()) {
    return inputError(scene.source, where, "vertex colour count differs from vertex count");
  }
  for (size_t i = 0; i < mesh.colors.size(); ++i) {
    const glm::vec4 c = mesh.colors[i];
    if (!(c.x >= 0.0f && c.x <= 1.0f && c.y >= 0.0f && c.y <= 1.0f && c.z >= 0.0f && c.z <= 1.0f &&
          c.w >= 0.0f && c.w <= 1.0f)) {
      return inputError(scene.source, fmt::format("{}, vertex colour {}", where, i),
                        "outside [0, 1]");
    }
  }
  return {};
}

// Warns about textures that read a UV set a mesh lacks (those triangles take the mean).
void warnMissingUvSets(Scene& scene, const Mesh& mesh, const std::string& where) {
  std::vector<uint8_t> used(scene.materials.size(), 0);
  for (uint32_t id : mesh.material_ids) used[id] = 1;
  for (size_t mi = 0; mi < used.size(); ++mi) {
    if (!used[mi]) continue;
    const Material& m = scene.materials[mi];
    for (const auto* binding : {&m.reflectance_texture, &m.emission_texture, &m.coverage_texture}) {
      if (*binding && mesh.uvSet((*binding)->uv_set).empty()) {
        scene.warnings.push_back(fmt::format(
            "{}: {} has no UV set {}, which material '{}' reads '{}' through: its triangles "
            "take the texture's mean",
            scene.source, where, (*binding)->uv_set, m.name, (*binding)->texture->source()));
      }
    }
  }
}

}  // namespace

Status checkScene(Scene& scene) {
  if (!finite3(scene.environment) || glm::any(glm::lessThan(scene.environment, glm::vec3(0.0f))) ||
      glm::any(glm::greaterThan(scene.environment, glm::vec3(kMaxRadiometricValue)))) {
    return inputError(scene.source, "environment",
                      fmt::format("({}, {}, {}) must be finite, non-negative and at most 1e15",
                                  scene.environment.x, scene.environment.y, scene.environment.z));
  }
  for (size_t mi = 0; mi < scene.materials.size(); ++mi) {
    const Material& m = scene.materials[mi];
    const std::string place = fmt::format("material '{}'", m.name);
    if (!finite3(m.reflectance) || glm::any(glm::lessThan(m.reflectance, glm::vec3(0.0f))) ||
        glm::any(glm::greaterThan(m.reflectance, glm::vec3(1.0f)))) {
      return inputError(scene.source, place,
                        fmt::format("reflectance ({}, {}, {}) is outside [0, 1]", m.reflectance.x,
                                    m.reflectance.y, m.reflectance.z));
    }
    if (!finite3(m.emission) || glm::any(glm::lessThan(m.emission, glm::vec3(0.0f))) ||
        glm::any(glm::greaterThan(m.emission, glm::vec3(kMaxRadiometricValue)))) {
      return inputError(scene.source, place,
                        fmt::format("emission ({}, {}, {}) must be finite, non-negative and at "
                                    "most 1e15",
                                    m.emission.x, m.emission.y, m.emission.z));
    }
    if (m.subsurface) {
      if (Status s = checkSubsurface(*m.subsurface); !s.ok()) {
        return inputError(scene.source, place + ": subsurface", s.error().message);
      }
    }
    PENUMBRA_TRY(checkCoverage(scene, m, place));
    if (m.isSpecular()) {
      if (!finite3(m.specular) || glm::any(glm::lessThan(m.specular, glm::vec3(0.0f))) ||
          glm::any(glm::greaterThan(m.specular, glm::vec3(1.0f)))) {
        return inputError(scene.source, place,
                          fmt::format("specular colour ({}, {}, {}) is outside [0, 1]",
                                      m.specular.x, m.specular.y, m.specular.z));
      }
      if (m.scattering == Scattering::kDielectric && !(m.ior >= 1.0f && m.ior <= 4.0f)) {
        return inputError(scene.source, place, fmt::format("ior {} is outside [1, 4]", m.ior));
      }
      if (m.subsurface) {
        return inputError(scene.source, place,
                          "a mirror or glass material cannot also have a subsurface medium");
      }
    }
  }
  for (size_t k = 0; k < scene.meshes.size(); ++k) {
    Mesh& mesh = scene.meshes[k];
    const std::string where = meshPlace(mesh, k);
    for (size_t i = 0; i < mesh.positions.size(); ++i) {
      if (!finite3(mesh.positions[i])) {
        return inputError(scene.source, fmt::format("{}, vertex {}", where, i),
                          "position is not a finite number");
      }
      const glm::vec3 p = mesh.positions[i];
      if (std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)}) > kMaxCoordinate) {
        return inputError(scene.source, fmt::format("{}, vertex {}", where, i),
                          fmt::format("position ({:g}, {:g}, {:g}) is more than {:g} m from the "
                                      "origin: areas and squared distances overflow single "
                                      "precision (check the units or the transform's scale)",
                                      p.x, p.y, p.z, kMaxCoordinate));
      }
    }
    if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size()) {
      return inputError(scene.source, where, "normal count differs from vertex count");
    }
    if (!mesh.uvs.empty() && mesh.uvs.size() != mesh.positions.size()) {
      return inputError(scene.source, where, "texture coordinate count differs from vertex count");
    }
    for (size_t i = 0; i < mesh.normals.size(); ++i) {
      glm::vec3& n = mesh.normals[i];
      const float len = glm::length(n);
      if (!finite3(n)) {
        return inputError(scene.source, fmt::format("{}, normal {}", where, i),
                          "normal is not a finite number");
      }
      // A zero normal carries no direction; shading falls back to the geometric normal.
      n = len > 0.0f ? n / len : glm::vec3(0.0f);
    }
    PENUMBRA_TRY(checkMeshAttributes(scene, mesh, where));
    if (mesh.material_ids.size() != mesh.triangles.size()) {
      return inputError(scene.source, where, "every triangle needs a material");
    }
    size_t degenerate = 0, first_degenerate = 0;
    const size_t nv = mesh.positions.size();
    for (size_t t = 0; t < mesh.triangles.size(); ++t) {
      const glm::uvec3 tri = mesh.triangles[t];
      if (tri.x >= nv || tri.y >= nv || tri.z >= nv) {
        return inputError(scene.source, fmt::format("{}, triangle {}", where, t),
                          fmt::format("vertex index out of range ({}, {}, {} with {} vertices)",
                                      tri.x, tri.y, tri.z, nv));
      }
      if (mesh.material_ids[t] >= scene.materials.size()) {
        return inputError(scene.source, fmt::format("{}, triangle {}", where, t),
                          "material index out of range");
      }
      const glm::vec3 c = glm::cross(mesh.positions[tri.y] - mesh.positions[tri.x],
                                     mesh.positions[tri.z] - mesh.positions[tri.x]);
      if (!(glm::dot(c, c) > 0.0f)) {
        if (degenerate == 0) first_degenerate = t;
        ++degenerate;
      }
    }
    warnMissingUvSets(scene, mesh, where);
    if (degenerate > 0 && degenerate == mesh.triangles.size()) {
      return inputError(scene.source, where, "every triangle is degenerate (zero area)");
    }
    if (degenerate > 0) {
      scene.warnings.push_back(
          fmt::format("{}: {} degenerate (zero-area) triangle(s), the first is triangle {}; they "
                      "are kept for numbering and never hit",
                      where, degenerate, first_degenerate));
    }
  }
  if (scene.triangleCount() == 0) {
    return inputError(scene.source, "", "the scene has no triangles");
  }
  const auto [lo, hi] = vertexBounds(scene);  // the scene has triangles, so lo <= hi
  return checkLights(scene.lights, 0.5f * (lo + hi), 0.5f * glm::length(hi - lo), scene.source);
}

Status validateScene(Scene& scene) {
  PENUMBRA_TRY(checkScene(scene));
  liftCoplanarEmitters(scene);  // a panel drawn on the ceiling wins over it
  return {};
}

glm::vec3 diffuseStandIn(const Material& m) {
  switch (m.scattering) {
    case Scattering::kMirror:
      return m.specular;
    case Scattering::kDielectric: {
      const float r0 = (m.ior - 1.0f) / (m.ior + 1.0f);
      return glm::vec3(r0 * r0);
    }
    case Scattering::kDiffuse:
      break;
  }
  return m.reflectance;
}

std::vector<std::string> diffuseStandInWarnings(const Scene& scene, const std::string& method) {
  std::vector<std::string> out;
  for (const Material& m : scene.materials) {
    if (!m.isSpecular()) continue;
    const bool mirror = m.scattering == Scattering::kMirror;
    out.push_back(fmt::format(
        "{}: material '{}' is {}: --method {} sees a diffuse surface of reflectance ({:.3g}, "
        "{:.3g}, {:.3g}) instead{} (pathtrace, whitted and photons follow its {})",
        scene.source, m.name, mirror ? "a mirror" : fmt::format("glass (ior {:.3g})", m.ior),
        method, m.reflectance.x, m.reflectance.y, m.reflectance.z, mirror ? "" : ", opaque",
        mirror ? "reflections" : "reflections and refractions"));
  }
  // The sky (scene/sky.h) is taken by the three radiosity methods and the path tracer.
  if (scene.sky && method != "progressive" && method != "pathtrace" && method != "matrix" &&
      method != "stochastic") {
    out.push_back(
        fmt::format("{}: --method {} does not take the sky yet: only its sun's beam, "
                    "if given, lights the scene (pathtrace, matrix, progressive and "
                    "stochastic take the sky)",
                    scene.source, method));
  }
  return out;
}

bool hasLightOtherThanSurfaces(const Scene& scene) {
  return !scene.lights.empty() || scene.sky.has_value() || scene.environment.x > 0.0f ||
         scene.environment.y > 0.0f || scene.environment.z > 0.0f;
}

Error noLightError(const Scene& scene, const std::string& method) {
  return inputError(scene.source, method,
                    "the scene emits no light (no light, no emitting surface that is there, no "
                    "sky and no environment): light it with --sky overcast or --environment "
                    "1,1,1, or add lights");
}

void scaleScene(Scene& scene, double s) {
  const float f = float(s);
  for (Mesh& m : scene.meshes) {
    for (glm::vec3& p : m.positions) p *= f;
  }
  for (Light& light : scene.lights) {
    std::visit(
        Overloaded{[&](PointLight& l) { l.position *= f; }, [&](SpotLight& l) { l.position *= f; },
                   [&](DirectionalLight&) {}, [&](LuminaireLight& l) { l.position *= f; }},
        light);
  }
  if (scene.camera) {
    scene.camera->position *= f;
    scene.camera->look_at *= f;
  }
  for (Opening& o : scene.openings) {
    for (glm::dvec3& c : o.corners) c *= s;
  }
  for (CalculationGrid& g : scene.calculation) {
    for (glm::dvec3& p : g.points) p *= s;
    g.spacing *= s;
    for (double& a : g.areas) a *= s * s;
  }
}

Camera defaultCamera(const Scene& scene) {
  glm::vec3 lo(INFINITY), hi(-INFINITY);
  for (const Mesh& m : scene.meshes) {
    for (const glm::vec3& p : m.positions) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
  }
  Camera cam;
  if (!(lo.x <= hi.x)) return cam;
  const glm::vec3 center = 0.5f * (lo + hi);
  const float radius = 0.5f * glm::length(hi - lo);
  const float distance = radius / std::tan(0.5f * cam.vertical_fov) + 1e-3f;
  cam.look_at = center;
  cam.position = center + glm::vec3(0.0f, 0.0f, distance);
  cam.up = glm::vec3(0.0f, 1.0f, 0.0f);
  return cam;
}

}  // namespace penumbra
