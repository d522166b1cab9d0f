#include "penumbra/geometry/icosphere.h"

#include <glm/geometric.hpp>

#include <cmath>
#include <cstdint>
#include <unordered_map>

namespace penumbra {

Mesh icosphere(int subdivisions) {
  Mesh mesh;
  mesh.name = "sphere";
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<glm::dvec3> p = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                               {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                               {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (glm::dvec3& v : p) v = glm::normalize(v);
  std::vector<glm::uvec3> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                               {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                               {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                               {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int level = 0; level < subdivisions; ++level) {
    // Each edge's midpoint once, keyed by its two vertices.
    std::unordered_map<uint64_t, uint32_t> midpoint;
    const auto mid = [&](uint32_t a, uint32_t b) {
      const uint64_t key = a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a);
      auto [it, inserted] = midpoint.try_emplace(key, uint32_t(p.size()));
      if (inserted) p.push_back(glm::normalize(p[a] + p[b]));
      return it->second;
    };
    std::vector<glm::uvec3> next;
    next.reserve(f.size() * 4);
    for (const glm::uvec3& tri : f) {
      const uint32_t ab = mid(tri.x, tri.y), bc = mid(tri.y, tri.z), ca = mid(tri.z, tri.x);
      next.push_back({tri.x, ab, ca});
      next.push_back({tri.y, bc, ab});
      next.push_back({tri.z, ca, bc});
      next.push_back({ab, bc, ca});
    }
    f.swap(next);
  }
  mesh.positions.reserve(p.size());
  for (const glm::dvec3& v : p) mesh.positions.push_back(glm::vec3(v));
  mesh.normals = mesh.positions;
  mesh.triangles = std::move(f);
  mesh.material_ids.assign(mesh.triangles.size(), 0);
  return mesh;
}

}  // namespace penumbra
