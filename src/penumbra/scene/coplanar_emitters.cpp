#include "penumbra/scene/coplanar_emitters.h"

#include <fmt/format.h>
#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <utility>

namespace penumbra {

namespace {

struct Tri {
  std::array<glm::dvec3, 3> p;
  glm::dvec3 normal{0.0};
  double edge = 0.0;  // longest edge
  glm::dvec3 lo{0.0}, hi{0.0};
};

Tri makeTri(const Mesh& m, const glm::uvec3& t) {
  Tri r;
  r.p = {glm::dvec3(m.positions[t.x]), glm::dvec3(m.positions[t.y]), glm::dvec3(m.positions[t.z])};
  const glm::dvec3 c = glm::cross(r.p[1] - r.p[0], r.p[2] - r.p[0]);
  const double len = glm::length(c);
  r.normal = len > 0.0 ? c / len : glm::dvec3(0.0);
  r.edge = std::max(
      {glm::length(r.p[1] - r.p[0]), glm::length(r.p[2] - r.p[1]), glm::length(r.p[0] - r.p[2])});
  r.lo = glm::min(r.p[0], glm::min(r.p[1], r.p[2]));
  r.hi = glm::max(r.p[0], glm::max(r.p[1], r.p[2]));
  return r;
}

// Whether emitter `e` lies on surface `s` with an overlap of some area (see the header).
bool coincide(const Tri& e, const Tri& s) {
  if (std::fabs(glm::dot(e.normal, s.normal)) < 1.0 - 1e-6) return false;
  const double tol = 1e-5 * e.edge;
  for (const glm::dvec3& q : e.p) {
    if (std::fabs(glm::dot(s.normal, q - s.p[0])) > tol) return false;
  }
  // The separating-axis test in the plane: the axes are the in-plane normals of the six edges.
  // Overlapping by less than the margin along one of them (touching edges) is no overlap.
  const double margin = 1e-4 * std::min(e.edge, s.edge);
  for (const Tri* owner : {&e, &s}) {
    for (int k = 0; k < 3; ++k) {
      const glm::dvec3 axis = glm::cross(s.normal, owner->p[(k + 1) % 3] - owner->p[k]);
      const double len = glm::length(axis);
      if (!(len > 0.0)) continue;
      double e_lo = std::numeric_limits<double>::infinity(), e_hi = -e_lo;
      double s_lo = e_lo, s_hi = -e_lo;
      for (int i = 0; i < 3; ++i) {
        const double a = glm::dot(axis, e.p[i]) / len, b = glm::dot(axis, s.p[i]) / len;
        e_lo = std::min(e_lo, a);
        e_hi = std::max(e_hi, a);
        s_lo = std::min(s_lo, b);
        s_hi = std::max(s_hi, b);
      }
      if (std::min(e_hi, s_hi) - std::max(e_lo, s_lo) <= margin) return false;
    }
  }
  return true;
}

std::string meshLabel(const Mesh& m, size_t k) {
  return m.name.empty() ? fmt::format("mesh {}", k) : fmt::format("'{}'", m.name);
}

struct EmitterRef {
  size_t mesh, triangle;
  Tri tri;
};

// The emitter triangles of the scene (non-degenerate), and the box around them.
std::vector<EmitterRef> emitterTriangles(const Scene& scene, glm::dvec3& lo, glm::dvec3& hi) {
  std::vector<EmitterRef> emitters;
  lo = glm::dvec3(std::numeric_limits<double>::infinity());
  hi = -lo;
  for (size_t k = 0; k < scene.meshes.size(); ++k) {
    const Mesh& m = scene.meshes[k];
    for (size_t t = 0; t < m.triangles.size(); ++t) {
      if (!scene.materials[m.material_ids[t]].isEmissive()) continue;
      Tri tri = makeTri(m, m.triangles[t]);
      if (tri.normal == glm::dvec3(0.0)) continue;
      const glm::dvec3 pad(1e-5 * tri.edge);
      lo = glm::min(lo, tri.lo - pad);
      hi = glm::max(hi, tri.hi + pad);
      emitters.push_back({k, t, tri});
    }
  }
  return emitters;
}

// Which emitters lie on a non-emitting surface (a uniform grid of the emitters' boxes over their
// union, about one emitter a cell), and per (emitter material, surface mesh) how many.
std::vector<uint8_t> findCoplanar(const Scene& scene, const std::vector<EmitterRef>& emitters,
                                  const glm::dvec3& lo, const glm::dvec3& hi,
                                  std::map<std::pair<uint32_t, size_t>, size_t>& pairs) {
  const int res = std::clamp(int(std::ceil(std::cbrt(double(emitters.size())))), 1, 64);
  const glm::dvec3 cell = glm::max((hi - lo) / double(res), glm::dvec3(1e-30));
  const auto cellOf = [&](const glm::dvec3& p) {
    return glm::clamp(glm::ivec3(glm::floor((p - lo) / cell)), glm::ivec3(0), glm::ivec3(res - 1));
  };
  const auto at = [&](int x, int y, int z) {
    return (size_t(z) * size_t(res) + size_t(y)) * size_t(res) + size_t(x);
  };
  std::vector<std::vector<uint32_t>> grid(size_t(res) * size_t(res) * size_t(res));
  for (size_t i = 0; i < emitters.size(); ++i) {
    const glm::dvec3 pad(1e-5 * emitters[i].tri.edge);
    const glm::ivec3 a = cellOf(emitters[i].tri.lo - pad), b = cellOf(emitters[i].tri.hi + pad);
    for (int z = a.z; z <= b.z; ++z) {
      for (int y = a.y; y <= b.y; ++y) {
        for (int x = a.x; x <= b.x; ++x) grid[at(x, y, z)].push_back(uint32_t(i));
      }
    }
  }
  std::vector<uint8_t> lifted(emitters.size(), 0);
  std::vector<uint32_t> seen(emitters.size(), 0);
  uint32_t stamp = 0;
  for (size_t k = 0; k < scene.meshes.size(); ++k) {
    const Mesh& m = scene.meshes[k];
    for (size_t t = 0; t < m.triangles.size(); ++t) {
      if (scene.materials[m.material_ids[t]].isEmissive()) continue;
      const Tri surface = makeTri(m, m.triangles[t]);
      if (glm::any(glm::greaterThan(surface.lo, hi)) || glm::any(glm::lessThan(surface.hi, lo)) ||
          surface.normal == glm::dvec3(0.0)) {
        continue;
      }
      ++stamp;
      const glm::ivec3 a = cellOf(surface.lo), b = cellOf(surface.hi);
      for (int z = a.z; z <= b.z; ++z) {
        for (int y = a.y; y <= b.y; ++y) {
          for (int x = a.x; x <= b.x; ++x) {
            for (uint32_t i : grid[at(x, y, z)]) {
              if (seen[i] == stamp) continue;
              seen[i] = stamp;
              if (lifted[i] || !coincide(emitters[i].tri, surface)) continue;
              const EmitterRef& e = emitters[i];
              ++pairs[{scene.meshes[e.mesh].material_ids[e.triangle], k}];
              lifted[i] = 1;
            }
          }
        }
      }
    }
  }
  return lifted;
}

// Moves mesh k's lifted triangles: their corners get new vertices (in the order the triangles
// name them, shared between lifted triangles of the mesh), moved along the mean of their
// triangles' normals by the largest delta.
size_t liftTriangles(Mesh& m, size_t k, const std::vector<EmitterRef>& emitters,
                     const std::vector<uint8_t>& lifted) {
  struct Move {
    glm::dvec3 normal{0.0};
    double delta = 0.0;
    uint32_t copy = 0;
  };
  std::map<uint32_t, Move> moves;
  std::vector<uint32_t> order;
  std::vector<size_t> mine;
  for (size_t i = 0; i < emitters.size(); ++i) {
    if (!lifted[i] || emitters[i].mesh != k) continue;
    mine.push_back(i);
    const Tri& tri = emitters[i].tri;
    const double far =
        std::max({glm::length(tri.p[0]), glm::length(tri.p[1]), glm::length(tri.p[2])});
    const double delta = std::max(1e-4 * tri.edge, 1e-6 * far);
    const glm::uvec3 idx = m.triangles[emitters[i].triangle];
    for (uint32_t v : {idx.x, idx.y, idx.z}) {
      if (!moves.count(v)) order.push_back(v);
      Move& mv = moves[v];
      mv.normal += tri.normal;
      mv.delta = std::max(mv.delta, delta);
    }
  }
  for (uint32_t v : order) {
    Move& mv = moves[v];
    mv.copy = uint32_t(m.positions.size());
    const double len = glm::length(mv.normal);
    const glm::dvec3 dir = len > 0.0 ? mv.normal / len : glm::dvec3(0.0);
    m.positions.push_back(glm::vec3(glm::dvec3(m.positions[v]) + mv.delta * dir));
    if (!m.normals.empty()) m.normals.push_back(m.normals[v]);
    if (!m.uvs.empty()) m.uvs.push_back(m.uvs[v]);
    for (std::vector<glm::vec2>& set : m.extra_uvs) {
      if (!set.empty()) set.push_back(set[v]);
    }
    if (!m.colors.empty()) m.colors.push_back(m.colors[v]);
  }
  for (size_t i : mine) {
    glm::uvec3& idx = m.triangles[emitters[i].triangle];
    idx = glm::uvec3(moves[idx.x].copy, moves[idx.y].copy, moves[idx.z].copy);
  }
  return mine.size();
}

}  // namespace

size_t liftCoplanarEmitters(Scene& scene) {
  glm::dvec3 lo, hi;
  const std::vector<EmitterRef> emitters = emitterTriangles(scene, lo, hi);
  if (emitters.empty()) return 0;
  std::map<std::pair<uint32_t, size_t>, size_t> pairs;
  const std::vector<uint8_t> lifted = findCoplanar(scene, emitters, lo, hi, pairs);
  size_t count = 0;
  for (size_t k = 0; k < scene.meshes.size(); ++k) {
    count += liftTriangles(scene.meshes[k], k, emitters, lifted);
  }
  for (const auto& [key, n] : pairs) {
    const std::string& material = scene.materials[key.first].name;
    scene.warnings.push_back(fmt::format(
        "{}: {} triangle(s) of emitter '{}' lie on {}: the emitter wins (lifted off the surface "
        "along its front, by 1e-4 of its size)",
        scene.source, n, material, meshLabel(scene.meshes[key.second], key.second)));
  }
  return count;
}

}  // namespace penumbra
