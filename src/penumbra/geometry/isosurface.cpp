#include "penumbra/geometry/isosurface.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <vector>

namespace penumbra {

Mesh isosurfaceMesh(const std::function<double(const glm::dvec3&)>& f, const glm::dvec3& lo,
                    const glm::dvec3& hi, int cells) {
  const int n = cells + 1;  // samples per axis
  const glm::dvec3 step = (hi - lo) / double(cells);
  auto vertexIndex = [&](int x, int y, int z) {
    return (uint64_t(z) * uint64_t(n) + uint64_t(y)) * uint64_t(n) + uint64_t(x);
  };
  auto position = [&](uint64_t i) {
    const int x = int(i % uint64_t(n)), y = int((i / uint64_t(n)) % uint64_t(n)),
              z = int(i / (uint64_t(n) * uint64_t(n)));
    return lo + glm::dvec3(x, y, z) * step;
  };
  std::vector<double> value(uint64_t(n) * uint64_t(n) * uint64_t(n));
  for (int z = 0; z < n; ++z) {
    for (int y = 0; y < n; ++y) {
      for (int x = 0; x < n; ++x) {
        value[vertexIndex(x, y, z)] = f(lo + glm::dvec3(x, y, z) * step);
      }
    }
  }
  // A sample exactly on the surface counts as slightly outside (simulation of simplicity): the
  // surface then never passes through a grid vertex, so every crossing is on an edge's inside
  // and the mesh stays closed (its triangles there are tiny, not missing).
  double scale = 0.0;
  for (double v : value) scale = std::max(scale, std::abs(v));
  for (double& v : value) {
    if (v == 0.0) v = -1e-7 * scale;
  }
  Mesh mesh;
  mesh.name = "isosurface";
  std::unordered_map<uint64_t, uint32_t> edge_vertex;
  // The surface's vertex on the grid edge (a, b), made once.
  auto edgeVertex = [&](uint64_t a, uint64_t b) {
    if (a > b) std::swap(a, b);
    const uint64_t key = a * value.size() + b;
    auto [it, added] = edge_vertex.emplace(key, uint32_t(mesh.positions.size()));
    if (added) {
      const double fa = value[a], fb = value[b];
      const double t = fa / (fa - fb);
      mesh.positions.emplace_back(glm::vec3(position(a) + t * (position(b) - position(a))));
    }
    return it->second;
  };
  auto emit = [&](uint32_t i0, uint32_t i1, uint32_t i2) {
    const glm::dvec3 p0(mesh.positions[i0]), p1(mesh.positions[i1]), p2(mesh.positions[i2]);
    const glm::dvec3 normal = glm::cross(p1 - p0, p2 - p0);
    // Outwards: against the gradient (f grows inwards), by central differences at the centroid.
    const glm::dvec3 c = (p0 + p1 + p2) / 3.0;
    const double h = 0.25 * std::min({step.x, step.y, step.z});
    const glm::dvec3 grad(f(c + glm::dvec3(h, 0, 0)) - f(c - glm::dvec3(h, 0, 0)),
                          f(c + glm::dvec3(0, h, 0)) - f(c - glm::dvec3(0, h, 0)),
                          f(c + glm::dvec3(0, 0, h)) - f(c - glm::dvec3(0, 0, h)));
    if (glm::dot(normal, grad) > 0.0) std::swap(i1, i2);
    mesh.triangles.emplace_back(i0, i1, i2);
  };
  // The six tetrahedra of a cube about its diagonal from corner 0 to corner 7 (corner bits:
  // x = 1, y = 2, z = 4).
  constexpr int kTets[6][4] = {{0, 1, 3, 7}, {0, 3, 2, 7}, {0, 2, 6, 7},
                               {0, 6, 4, 7}, {0, 4, 5, 7}, {0, 5, 1, 7}};
  for (int z = 0; z < cells; ++z) {
    for (int y = 0; y < cells; ++y) {
      for (int x = 0; x < cells; ++x) {
        std::array<uint64_t, 8> corner;
        for (int c = 0; c < 8; ++c)
          corner[size_t(c)] = vertexIndex(x + (c & 1), y + ((c >> 1) & 1), z + ((c >> 2) & 1));
        for (const auto& tet : kTets) {
          std::array<uint64_t, 4> in, out;
          size_t ni = 0, no = 0;
          for (int k : tet) {
            const uint64_t v = corner[size_t(k)];
            if (value[v] > 0.0) {
              in[ni++] = v;
            } else {
              out[no++] = v;
            }
          }
          if (ni == 1) {
            emit(edgeVertex(in[0], out[0]), edgeVertex(in[0], out[1]), edgeVertex(in[0], out[2]));
          } else if (ni == 3) {
            emit(edgeVertex(out[0], in[0]), edgeVertex(out[0], in[1]), edgeVertex(out[0], in[2]));
          } else if (ni == 2) {
            const uint32_t a = edgeVertex(in[0], out[0]), b = edgeVertex(in[0], out[1]),
                           c = edgeVertex(in[1], out[1]), d = edgeVertex(in[1], out[0]);
            emit(a, b, c);
            emit(a, c, d);
          }
        }
      }
    }
  }
  mesh.material_ids.assign(mesh.triangles.size(), 0);
  return mesh;
}

}  // namespace penumbra
