#include "penumbra/geometry/shading_normals.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <unordered_map>

namespace penumbra {

namespace {

struct PositionHash {
  size_t operator()(const glm::vec3& p) const {
    uint32_t b[3];
    std::memcpy(b, &p, sizeof(b));
    return size_t(b[0]) * 73856093u ^ size_t(b[1]) * 19349663u ^ size_t(b[2]) * 83492791u;
  }
};

}  // namespace

std::vector<glm::vec3> cornerShadingNormals(const Scene& scene, double crease_deg) {
  const FlatTriangles flat = flattenScene(scene);
  const size_t nt = flat.triangles.size();
  std::vector<glm::vec3> out(3 * nt, glm::vec3(0.0f));
  // Face normals (unit) and twice the areas.
  std::vector<glm::dvec3> face(nt, glm::dvec3(0.0));
  std::vector<double> area2(nt, 0.0);
  for (size_t t = 0; t < nt; ++t) {
    const glm::uvec3 tri = flat.triangles[t];
    const glm::dvec3 c = glm::cross(glm::dvec3(flat.positions[tri.y] - flat.positions[tri.x]),
                                    glm::dvec3(flat.positions[tri.z] - flat.positions[tri.x]));
    area2[t] = glm::length(c);
    if (area2[t] > 0.0) face[t] = c / area2[t];
  }
  // Which meshes bring their own normals (flattenScene keeps the meshes' order).
  std::vector<const Mesh*> mesh_of(nt, nullptr);
  std::vector<glm::uvec3> local(nt);
  {
    size_t t = 0;
    for (const Mesh& m : scene.meshes) {
      for (const glm::uvec3& tri : m.triangles) {
        mesh_of[t] = &m;
        local[t++] = tri;
      }
    }
  }
  // Welded corners: the triangles meeting at each distinct position.
  std::unordered_map<glm::vec3, std::vector<uint32_t>, PositionHash> at;
  for (size_t t = 0; t < nt; ++t) {
    if (area2[t] <= 0.0 || !mesh_of[t]->normals.empty()) continue;
    for (int k = 0; k < 3; ++k) at[flat.positions[flat.triangles[t][k]]].push_back(uint32_t(t));
  }
  const double cos_crease = std::cos(crease_deg * 3.14159265358979323846 / 180.0);
  for (size_t t = 0; t < nt; ++t) {
    if (area2[t] <= 0.0) continue;
    for (int k = 0; k < 3; ++k) {
      glm::dvec3 n(0.0);
      if (!mesh_of[t]->normals.empty()) {
        n = glm::dvec3(mesh_of[t]->normals[local[t][k]]);
      } else {
        const glm::vec3 here = flat.positions[flat.triangles[t][k]];
        for (uint32_t u : at[here]) {
          if (glm::dot(face[u], face[t]) < cos_crease) continue;
          // Weighted by the triangle's angle at the corner (Thuermer and Wuethrich 1998): the
          // result does not depend on how a face was split into triangles, as area weights do.
          const glm::uvec3 tri = flat.triangles[u];
          int c = 0;
          while (c < 2 && flat.positions[tri[c]] != here) ++c;
          const glm::dvec3 a = glm::dvec3(flat.positions[tri[(c + 1) % 3]]) - glm::dvec3(here);
          const glm::dvec3 b = glm::dvec3(flat.positions[tri[(c + 2) % 3]]) - glm::dvec3(here);
          const double la = glm::length(a), lb = glm::length(b);
          if (la <= 0.0 || lb <= 0.0) continue;
          n += face[u] * std::acos(std::clamp(glm::dot(a, b) / (la * lb), -1.0, 1.0));
        }
      }
      const double len = glm::length(n);
      n = len > 0.0 ? n / len : face[t];
      if (glm::dot(n, face[t]) <= 0.0) n = face[t];  // never behind its own triangle
      out[3 * t + size_t(k)] = glm::vec3(n);
    }
  }
  return out;
}

}  // namespace penumbra
