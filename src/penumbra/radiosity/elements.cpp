#include "penumbra/radiosity/elements.h"

#include "penumbra/core/check.h"
#include "penumbra/core/memory.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <unordered_map>

namespace penumbra {

namespace {

// Exact-position key for welding.
struct VertexKey {
  uint32_t p[3];
  bool operator==(const VertexKey& o) const {
    return std::memcmp(this, &o, sizeof(VertexKey)) == 0;
  }
};
struct VertexKeyHash {
  size_t operator()(const VertexKey& k) const {
    uint64_t h = 1469598103934665603ull;
    const auto* b = reinterpret_cast<const uint8_t*>(&k);
    for (size_t i = 0; i < sizeof(VertexKey); ++i) h = (h ^ b[i]) * 1099511628211ull;
    return size_t(h);
  }
};

bool lessPoint(const glm::vec3& a, const glm::vec3& b) {
  if (a.x != b.x) return a.x < b.x;
  if (a.y != b.y) return a.y < b.y;
  return a.z < b.z;
}

// Point i/m of the way from a to b, computed from the smaller end point (in lexicographic order)
// so that both triangles sharing the edge get the same float.
glm::vec3 edgePoint(const glm::vec3& a, const glm::vec3& b, int i, int m) {
  if (lessPoint(b, a)) return edgePoint(b, a, m - i, m);
  if (i == 0) return a;
  if (i == m) return b;
  return a + (b - a) * (float(i) / float(m));
}

}  // namespace

size_t elementBytes(size_t count) {
  // Per element: triangle, source, material, area, centroid, normal, ~1.5 vertices, and the
  // welding table while meshing.
  return count * (12 + 4 + 4 + 4 + 12 + 12 + 18 + 48);
}

Expected<Elements> meshElements(const Scene& scene, const MeshingOptions& options) {
  Elements out;
  out.scene = flattenScene(scene);
  const FlatTriangles& flat = out.scene;
  const size_t n_tri = flat.triangles.size();
  std::vector<double> area(n_tri);
  double total = 0.0;
  for (size_t t = 0; t < n_tri; ++t) {
    const glm::uvec3 tri = flat.triangles[t];
    const glm::dvec3 a = flat.positions[tri.x], b = flat.positions[tri.y],
                     c = flat.positions[tri.z];
    area[t] = 0.5 * glm::length(glm::cross(b - a, c - a));
    total += area[t];
  }
  if (!(total > 0.0)) return inputError(scene.source, "", "the scene has no surface area");
  double target_area = options.max_area;
  if (!(target_area > 0.0)) {
    if (options.target_elements == 0) {
      return inputError("", "--elements", "must be at least 1");
    }
    target_area = total / double(options.target_elements);
  }
  // Levels: the fewest 1-to-4 refinements that bring each triangle to the target area.
  std::vector<int> level(n_tri, -1);
  uint64_t count = 0;
  for (size_t t = 0; t < n_tri; ++t) {
    if (!(area[t] > total * 1e-12)) continue;  // degenerate: no element
    // The level whose element area is nearest the target in ratio (4^k within a factor 2).
    const double ratio = area[t] / target_area;
    int k = ratio <= 1.0 ? 0 : int(std::lround(std::log(ratio) / std::log(4.0)));
    k = std::clamp(k, 0, options.max_level);
    level[t] = k;
    count += uint64_t(1) << (2 * k);
  }
  if (count == 0) return inputError(scene.source, "", "the scene has no non-degenerate triangle");
  if (count > (uint64_t(1) << 31)) {
    return inputError("", "--elements",
                      fmt::format("{} elements are more than this solver can index", count));
  }
  PENUMBRA_TRY(checkMemory(elementBytes(count), fmt::format("{} radiosity elements", count)));

  out.triangles.reserve(count);
  out.source.reserve(count);
  out.material.reserve(count);
  out.area.reserve(count);
  out.centroid.reserve(count);
  out.normal.reserve(count);
  std::unordered_map<VertexKey, uint32_t, VertexKeyHash> weld;
  weld.reserve(count);
  std::vector<uint32_t> grid;
  for (size_t t = 0; t < n_tri; ++t) {
    if (level[t] < 0) continue;
    const glm::uvec3 tri = flat.triangles[t];
    const glm::vec3 a = flat.positions[tri.x], b = flat.positions[tri.y], c = flat.positions[tri.z];
    const glm::vec3 normal = glm::normalize(glm::cross(b - a, c - a));
    const int m = 1 << level[t];
    // Grid point (i, j): a + i/m (b - a) + j/m (c - a), i + j <= m. Edge points come from
    // edgePoint so that neighbours agree exactly.
    auto point = [&](int i, int j) -> glm::vec3 {
      if (j == 0) return edgePoint(a, b, i, m);
      if (i == 0) return edgePoint(a, c, j, m);
      if (i + j == m) return edgePoint(b, c, j, m);
      return a + (b - a) * (float(i) / float(m)) + (c - a) * (float(j) / float(m));
    };
    VertexKey key{};
    grid.assign(size_t(m + 1) * size_t(m + 1), 0);
    for (int j = 0; j <= m; ++j) {
      for (int i = 0; i + j <= m; ++i) {
        const glm::vec3 p = point(i, j);
        std::memcpy(key.p, &p, sizeof(key.p));
        auto [it, inserted] = weld.try_emplace(key, uint32_t(out.positions.size()));
        if (inserted) out.positions.push_back(p);
        grid[size_t(j) * size_t(m + 1) + size_t(i)] = it->second;
      }
    }
    auto at = [&](int i, int j) { return grid[size_t(j) * size_t(m + 1) + size_t(i)]; };
    const float element_area = float(area[t] / double(m * m));
    auto add = [&](uint32_t p0, uint32_t p1, uint32_t p2) {
      out.triangles.emplace_back(p0, p1, p2);
      out.source.push_back(uint32_t(t));
      out.material.push_back(flat.material_ids[t]);
      out.area.push_back(element_area);
      out.centroid.push_back((out.positions[p0] + out.positions[p1] + out.positions[p2]) / 3.0f);
      out.normal.push_back(normal);
    };
    for (int j = 0; j < m; ++j) {
      for (int i = 0; i + j < m; ++i) {
        add(at(i, j), at(i + 1, j), at(i, j + 1));  // same winding as (a, b, c)
        if (i + j + 1 < m) add(at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
      }
    }
  }
  PENUMBRA_CHECK(out.triangles.size() == count);
  return out;
}

std::vector<glm::vec3> Elements::cornerAverage(std::span<const glm::vec3> per_element,
                                               float crease_degrees) const {
  PENUMBRA_CHECK(per_element.size() == size());
  // Elements around each vertex (compressed rows).
  std::vector<uint32_t> start(positions.size() + 1, 0);
  for (const glm::uvec3& t : triangles) {
    for (int k = 0; k < 3; ++k) ++start[t[k] + 1];
  }
  for (size_t v = 0; v < positions.size(); ++v) start[v + 1] += start[v];
  std::vector<uint32_t> around(start.back()), fill(start.begin(), start.end() - 1);
  for (size_t e = 0; e < size(); ++e) {
    for (int k = 0; k < 3; ++k) around[fill[triangles[e][k]]++] = uint32_t(e);
  }
  const float cos_crease = std::cos(crease_degrees * 3.14159265358979f / 180.0f);
  std::vector<glm::vec3> out(3 * size());
  for (size_t e = 0; e < size(); ++e) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = triangles[e][k];
      glm::dvec3 sum(0.0);
      double weight = 0.0;
      for (uint32_t i = start[v]; i < start[v + 1]; ++i) {
        const uint32_t f = around[i];
        if (glm::dot(normal[e], normal[f]) < cos_crease) continue;
        sum += glm::dvec3(per_element[f]) * double(area[f]);
        weight += double(area[f]);
      }
      out[3 * e + size_t(k)] = weight > 0.0 ? glm::vec3(sum / weight) : per_element[e];
    }
  }
  return out;
}

}  // namespace penumbra
