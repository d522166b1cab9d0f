#include "penumbra/geometry/shading_normals.h"

#include "penumbra/geometry/weld.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>

namespace penumbra {

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
  // Welded corners: the triangles meeting at each distinct position (ids by position, then
  // the triangles of each id in one array).
  const std::vector<uint32_t> weld = weldPositions(flat.positions);
  const uint32_t welded = weld.empty() ? 0 : *std::max_element(weld.begin(), weld.end()) + 1;
  std::vector<uint32_t> first(size_t(welded) + 1, 0);
  auto counted = [&](size_t t) { return area2[t] > 0.0 && mesh_of[t]->normals.empty(); };
  for (size_t t = 0; t < nt; ++t) {
    if (!counted(t)) continue;
    for (int k = 0; k < 3; ++k) ++first[weld[flat.triangles[t][k]] + 1];
  }
  for (size_t i = 1; i < first.size(); ++i) first[i] += first[i - 1];
  // (triangle, corner) pairs at each welded position.
  std::vector<std::pair<uint32_t, uint32_t>> at(first.back());
  {
    std::vector<uint32_t> next(first.begin(), first.end() - 1);
    for (size_t t = 0; t < nt; ++t) {
      if (!counted(t)) continue;
      for (uint32_t k = 0; k < 3; ++k) at[next[weld[flat.triangles[t][k]]]++] = {uint32_t(t), k};
    }
  }
  // Each triangle's angle at each corner: the weight of its normal there (Thuermer and
  // Wuethrich 1998): the result does not depend on how a face was split into triangles, as
  // area weights do.
  std::vector<glm::dvec3> angle(nt, glm::dvec3(0.0));
  for (size_t t = 0; t < nt; ++t) {
    if (!counted(t)) continue;
    for (int c = 0; c < 3; ++c) {
      const glm::dvec3 here(flat.positions[flat.triangles[t][c]]);
      const glm::dvec3 a = glm::dvec3(flat.positions[flat.triangles[t][(c + 1) % 3]]) - here;
      const glm::dvec3 b = glm::dvec3(flat.positions[flat.triangles[t][(c + 2) % 3]]) - here;
      const double la = glm::length(a), lb = glm::length(b);
      if (la > 0.0 && lb > 0.0) {
        angle[t][c] = std::acos(std::clamp(glm::dot(a, b) / (la * lb), -1.0, 1.0));
      }
    }
  }
  const double cos_crease = std::cos(crease_deg * 3.14159265358979323846 / 180.0);
  for (size_t t = 0; t < nt; ++t) {
    if (area2[t] <= 0.0) continue;
    for (int k = 0; k < 3; ++k) {
      glm::dvec3 n(0.0);
      if (!mesh_of[t]->normals.empty()) {
        n = glm::dvec3(mesh_of[t]->normals[local[t][k]]);
      } else {
        const uint32_t w = weld[flat.triangles[t][k]];
        for (uint32_t i = first[w]; i < first[w + 1]; ++i) {
          const auto [u, c] = at[i];
          if (glm::dot(face[u], face[t]) < cos_crease) continue;
          n += face[u] * angle[u][int(c)];
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
