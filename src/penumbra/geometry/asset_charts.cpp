#include "penumbra/geometry/asset_charts.h"

#include "penumbra/geometry/chart_atlas.h"

#include <glm/geometric.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <numeric>
#include <unordered_map>

namespace penumbra {

namespace {

double cross2(const glm::dvec2& a, const glm::dvec2& b) {
  return a.x * b.y - a.y * b.x;
}

// The area of the intersection of two triangles in the plane (Sutherland-Hodgman, each made
// counter-clockwise).
double triangleOverlap(std::array<glm::dvec2, 3> a, std::array<glm::dvec2, 3> b) {
  if (cross2(a[1] - a[0], a[2] - a[0]) < 0.0) std::swap(a[1], a[2]);
  if (cross2(b[1] - b[0], b[2] - b[0]) < 0.0) std::swap(b[1], b[2]);
  std::vector<glm::dvec2> poly(a.begin(), a.end()), next;
  for (int e = 0; e < 3 && !poly.empty(); ++e) {
    const glm::dvec2 p = b[size_t(e)], q = b[size_t((e + 1) % 3)];
    const auto inside = [&](const glm::dvec2& x) { return cross2(q - p, x - p) >= 0.0; };
    next.clear();
    for (size_t i = 0; i < poly.size(); ++i) {
      const glm::dvec2 c = poly[i], d = poly[(i + 1) % poly.size()];
      const bool ci = inside(c), di = inside(d);
      if (ci) next.push_back(c);
      if (ci != di) {
        const double t = cross2(q - p, c - p) / cross2(q - p, c - d);
        next.push_back(c + t * (d - c));
      }
    }
    poly.swap(next);
  }
  double area = 0.0;
  for (size_t i = 0; i < poly.size(); ++i) area += cross2(poly[i], poly[(i + 1) % poly.size()]);
  return 0.5 * std::abs(area);
}

// s1 / s2 of the map from the triangle (metres, in its plane) to its UVs.
double stretchOf(const glm::dvec3& p0, const glm::dvec3& p1, const glm::dvec3& p2,
                 const glm::dvec2& u0, const glm::dvec2& u1, const glm::dvec2& u2) {
  const glm::dvec3 e1 = p1 - p0, e2 = p2 - p0;
  const double l1 = glm::length(e1);
  if (!(l1 > 0.0)) return 1.0;
  const glm::dvec3 x = e1 / l1;
  const glm::dvec3 yv = e2 - glm::dot(e2, x) * x;
  const double ly = glm::length(yv);
  if (!(ly > 0.0)) return 1.0;
  // J [q1 q2] = [w1 w2]: q1 = (l1, 0), q2 = (e2 . x, ly).
  const glm::dvec2 w1 = u1 - u0, w2 = u2 - u0;
  const double a = glm::dot(e2, x);
  // J = [w1 w2] [q1 q2]^-1, [q1 q2]^-1 = [[1/l1, -a/(l1 ly)], [0, 1/ly]].
  const double j00 = w1.x / l1, j10 = w1.y / l1;
  const double j01 = (w2.x - a * j00) / ly, j11 = (w2.y - a * j10) / ly;
  const double p = j00 * j00 + j10 * j10, q = j01 * j01 + j11 * j11, r = j00 * j01 + j10 * j11;
  const double mean = 0.5 * (p + q), dev = std::sqrt(0.25 * (p - q) * (p - q) + r * r);
  const double s1 = std::sqrt(mean + dev), s2 = std::sqrt(std::max(mean - dev, 0.0));
  return s2 > 0.0 ? s1 / s2 : 1.0;
}

// Whether some two faces of the block overlap in UV space (a positive area in common, beyond
// rounding); their indices in *a, *b.
bool findOverlap(const std::vector<std::array<glm::dvec2, 3>>& uv, size_t* a, size_t* b) {
  const size_t n = uv.size();
  const int grid = std::clamp(int(std::sqrt(double(n)) * 2.0), 1, 512);
  std::vector<std::vector<uint32_t>> cells(size_t(grid) * size_t(grid));
  const auto cellOf = [&](double v) { return std::clamp(int(v * grid), 0, grid - 1); };
  for (size_t f = 0; f < n; ++f) {
    glm::dvec2 lo = glm::min(uv[f][0], glm::min(uv[f][1], uv[f][2]));
    glm::dvec2 hi = glm::max(uv[f][0], glm::max(uv[f][1], uv[f][2]));
    for (int y = cellOf(lo.y); y <= cellOf(hi.y); ++y) {
      for (int x = cellOf(lo.x); x <= cellOf(hi.x); ++x) {
        cells[size_t(y) * size_t(grid) + size_t(x)].push_back(uint32_t(f));
      }
    }
  }
  const auto area = [&](size_t f) {
    return 0.5 * std::abs(cross2(uv[f][1] - uv[f][0], uv[f][2] - uv[f][0]));
  };
  for (const std::vector<uint32_t>& cell : cells) {
    for (size_t i = 0; i < cell.size(); ++i) {
      for (size_t j = i + 1; j < cell.size(); ++j) {
        const double common = triangleOverlap(uv[cell[i]], uv[cell[j]]);
        if (common > 1e-4 * std::min(area(cell[i]), area(cell[j])) && common > 1e-12) {
          *a = cell[i];
          *b = cell[j];
          return true;
        }
      }
    }
  }
  return false;
}

// Islands of a block: faces joined by edges whose two ends agree in position and UV.
struct VertexKey {
  std::array<uint32_t, 5> bits;
  bool operator==(const VertexKey&) const = default;
  bool operator<(const VertexKey& o) const { return bits < o.bits; }
};
struct EdgeKey {
  VertexKey a, b;
  bool operator==(const EdgeKey&) const = default;
};
struct EdgeHash {
  size_t operator()(const EdgeKey& k) const {
    uint64_t h = 1469598103934665603ull;
    for (uint32_t v : k.a.bits) h = (h ^ v) * 1099511628211ull;
    for (uint32_t v : k.b.bits) h = (h ^ v) * 1099511628211ull;
    return size_t(h);
  }
};

uint32_t find(std::vector<uint32_t>& parent, uint32_t x) {
  while (parent[x] != x) x = parent[x] = parent[parent[x]];
  return x;
}

// Islands of a block's faces `kept` by union-find over edges whose ends agree in position and
// UV: the union-find's parents (find() gives each face's island root).
std::vector<uint32_t> islandRoots(std::span<const glm::vec3> positions,
                                  std::span<const glm::uvec3> triangles,
                                  std::span<const SurfaceFace> faces, const AssetLightmapUvs& asset,
                                  const std::vector<uint32_t>& kept) {
  std::vector<uint32_t> parent(kept.size());
  std::iota(parent.begin(), parent.end(), 0u);
  std::unordered_map<EdgeKey, uint32_t, EdgeHash> first_face;
  for (size_t i = 0; i < kept.size(); ++i) {
    const uint32_t f = kept[i];
    const glm::uvec3 tri = triangles[faces[f].triangle];
    VertexKey v[3];
    for (int k = 0; k < 3; ++k) {
      const glm::vec3 p = positions[tri[k]];
      const glm::vec2 u = asset.corner_uv[3 * size_t(faces[f].triangle) + size_t(k)];
      v[k].bits = {std::bit_cast<uint32_t>(p.x), std::bit_cast<uint32_t>(p.y),
                   std::bit_cast<uint32_t>(p.z), std::bit_cast<uint32_t>(u.x),
                   std::bit_cast<uint32_t>(u.y)};
    }
    for (int k = 0; k < 3; ++k) {
      EdgeKey e{v[k], v[(k + 1) % 3]};
      if (e.b < e.a) std::swap(e.a, e.b);
      auto [it, fresh] = first_face.emplace(e, uint32_t(i));
      if (!fresh) parent[find(parent, uint32_t(i))] = find(parent, it->second);
    }
  }
  return parent;
}

// The charts of the faces outside every block (buildCharts), as a chart set over all `faces`.
ChartSet generatedCharts(std::span<const glm::vec3> positions,
                         std::span<const glm::uvec3> triangles,
                         std::span<const uint32_t> material_ids, std::span<const SurfaceFace> faces,
                         const ChartOptions& options, const std::vector<SurfaceFace>& others,
                         const std::vector<uint32_t>& other_index) {
  const size_t nf = faces.size();
  ChartSet set;
  set.face_chart.assign(nf, -1);
  set.uv.assign(3 * nf, glm::dvec2(0.0));
  set.stretch.assign(nf, 1.0);
  if (!others.empty()) {
    ChartSet sub = buildCharts(positions, triangles, material_ids, others, options);
    for (size_t i = 0; i < others.size(); ++i) {
      const size_t f = other_index[i];
      set.face_chart[f] = sub.face_chart[i];
      set.stretch[f] = sub.stretch[i];
      for (int k = 0; k < 3; ++k) set.uv[3 * f + size_t(k)] = sub.uv[3 * i + size_t(k)];
    }
    for (Chart& c : sub.charts) {
      for (uint32_t& f : c.faces) f = other_index[f];
    }
    set.charts = std::move(sub.charts);
  }
  return set;
}

}  // namespace

Expected<ChartSet> chartsWithAssetUvs(std::span<const glm::vec3> positions,
                                      std::span<const glm::uvec3> triangles,
                                      std::span<const uint32_t> material_ids,
                                      std::span<const SurfaceFace> faces,
                                      const ChartOptions& options, const AssetLightmapUvs& asset,
                                      std::vector<int32_t>& face_island) {
  const size_t nf = faces.size();
  std::vector<SurfaceFace> others;
  std::vector<uint32_t> other_index;
  std::vector<std::vector<uint32_t>> block_faces(asset.block_name.size());
  for (size_t f = 0; f < nf; ++f) {
    const int32_t b = asset.block[faces[f].triangle];
    if (!faces[f].back && b >= 0) {
      block_faces[size_t(b)].push_back(uint32_t(f));
    } else {
      others.push_back(faces[f]);
      other_index.push_back(uint32_t(f));
    }
  }
  ChartSet set =
      generatedCharts(positions, triangles, material_ids, faces, options, others, other_index);
  face_island.assign(nf, -1);
  int32_t islands = 0;
  for (size_t b = 0; b < block_faces.size(); ++b) {
    if (block_faces[b].empty()) continue;
    const std::string& name = asset.block_name[b];
    Chart chart;
    chart.asset_block = int32_t(b);
    glm::dvec3 normal_sum(0.0);
    double area_uv = 0.0;
    std::vector<std::array<glm::dvec2, 3>> uvs;
    std::vector<uint32_t> kept;
    for (uint32_t f : block_faces[b]) {
      const uint32_t t = faces[f].triangle;
      const glm::uvec3 tri = triangles[t];
      std::array<glm::dvec2, 3> uv;
      for (int k = 0; k < 3; ++k) {
        uv[size_t(k)] = glm::dvec2(asset.corner_uv[3 * size_t(t) + size_t(k)]);
        const glm::dvec2 u = uv[size_t(k)];
        if (!(u.x >= -1e-6 && u.x <= 1.0 + 1e-6 && u.y >= -1e-6 && u.y <= 1.0 + 1e-6)) {
          return inputError(name, fmt::format("triangle {} TEXCOORD_1", t - asset.block_first[b]),
                            fmt::format("UV ({:g}, {:g}) is outside [0, 1]: a lightmap's UVs lie "
                                        "in its texture (or bake with --lightmap-uv generate)",
                                        u.x, u.y));
        }
      }
      const glm::dvec3 p0(positions[tri.x]), p1(positions[tri.y]), p2(positions[tri.z]);
      const glm::dvec3 n = glm::cross(p1 - p0, p2 - p0);
      const double a3 = 0.5 * glm::length(n);
      const double auv = 0.5 * std::abs(cross2(uv[1] - uv[0], uv[2] - uv[0]));
      if (!(a3 > 0.0)) continue;  // degenerate: no texels, as in every atlas
      if (!(auv > 0.0)) {
        return inputError(name, fmt::format("triangle {} TEXCOORD_1", t - asset.block_first[b]),
                          "the triangle has an area but its lightmap UVs have none");
      }
      chart.area += a3;
      area_uv += auv;
      normal_sum += n * 0.5;
      uvs.push_back(uv);
      kept.push_back(f);
    }
    if (kept.empty()) continue;
    size_t oa = 0, ob = 0;
    if (findOverlap(uvs, &oa, &ob)) {
      return inputError(
          name, "TEXCOORD_1",
          fmt::format("the UVs of triangles {} and {} overlap: a lightmap needs a texel of its own "
                      "for every point (lay the UVs out without overlaps, or bake with "
                      "--lightmap-uv generate)",
                      faces[kept[oa]].triangle - asset.block_first[b],
                      faces[kept[ob]].triangle - asset.block_first[b]));
    }
    // A UV unit spans sqrt(area / UV area) metres: the texel density applies as to any chart.
    const double scale = std::sqrt(chart.area / area_uv);
    const double len = glm::length(normal_sum);
    chart.normal = len > 0.0 ? normal_sum / len : glm::dvec3(0.0, 0.0, 1.0);
    const int32_t c = int32_t(set.charts.size());
    std::vector<uint32_t> parent = islandRoots(positions, triangles, faces, asset, kept);
    std::vector<int32_t> island_of_root(kept.size(), -1);
    for (size_t i = 0; i < kept.size(); ++i) {
      const uint32_t f = kept[i];
      const uint32_t root = find(parent, uint32_t(i));
      if (island_of_root[root] < 0) island_of_root[root] = islands++;
      face_island[f] = island_of_root[root];
      set.face_chart[f] = c;
      const glm::uvec3 tri = triangles[faces[f].triangle];
      for (int k = 0; k < 3; ++k) set.uv[3 * size_t(f) + size_t(k)] = uvs[i][size_t(k)] * scale;
      set.stretch[f] = stretchOf(glm::dvec3(positions[tri.x]), glm::dvec3(positions[tri.y]),
                                 glm::dvec3(positions[tri.z]), uvs[i][0], uvs[i][1], uvs[i][2]);
      chart.faces.push_back(f);
    }
    set.charts.push_back(std::move(chart));
  }
  return set;
}

namespace {

// Islands that own no element (all their texels shared with a bigger island at this density)
// join the island of an element that holds one of their faces: the union-find's parents.
std::vector<uint32_t> islandsWithTexels(const ChartAtlas& atlas,
                                        const std::vector<int32_t>& face_island, int32_t islands) {
  const size_t ne = atlas.elementCount();
  std::vector<uint32_t> parent(static_cast<size_t>(islands));
  std::iota(parent.begin(), parent.end(), 0u);
  std::vector<uint8_t> owns(size_t(islands), 0);
  for (size_t e = 0; e < ne; ++e) {
    const int32_t i = face_island[atlas.element_face[e]];
    if (i >= 0) owns[size_t(i)] = 1;
  }
  for (size_t e = 0; e < ne; ++e) {
    const int32_t own = face_island[atlas.element_face[e]];
    if (own < 0) continue;
    for (uint32_t k = atlas.element_face_first[e]; k < atlas.element_face_first[e + 1]; ++k) {
      const int32_t other = face_island[atlas.element_faces[k]];
      if (other >= 0 && !owns[size_t(other)]) {
        parent[find(parent, uint32_t(other))] = find(parent, uint32_t(own));
      }
    }
  }
  return parent;
}

// The atlas's per-element arrays in the order `order` (new position k holds old element
// order[k]), with their charts.
void permuteElements(ChartAtlas& atlas, const std::vector<uint32_t>& order,
                     std::vector<uint32_t> element_chart) {
  const size_t ne = atlas.elementCount();
  const auto permute = [&](auto& v) {
    auto copy = v;
    for (size_t k = 0; k < ne; ++k) v[k] = copy[order[k]];
  };
  std::vector<uint32_t> face_first(ne + 1, 0), face_list;
  face_list.reserve(atlas.element_faces.size());
  for (size_t k = 0; k < ne; ++k) {
    const uint32_t e = order[k];
    for (uint32_t j = atlas.element_face_first[e]; j < atlas.element_face_first[e + 1]; ++j) {
      face_list.push_back(atlas.element_faces[j]);
    }
    face_first[k + 1] = uint32_t(face_list.size());
  }
  permute(atlas.element_texel);
  permute(atlas.element_area);
  permute(atlas.element_position);
  permute(atlas.element_face);
  permute(atlas.element_barycentric);
  permute(atlas.element_normal);
  permute(element_chart);
  atlas.element_chart = element_chart;
  atlas.element_face_first = std::move(face_first);
  atlas.element_faces = std::move(face_list);
  for (size_t k = 0; k < ne; ++k) atlas.texel_element[atlas.element_texel[k]] = int32_t(k);
}

}  // namespace

void splitAssetBlocks(ChartAtlas& atlas, const std::vector<int32_t>& face_island) {
  const size_t nc = atlas.charts.charts.size();
  const size_t ne = atlas.elementCount();
  int32_t islands = 0;
  for (int32_t i : face_island) islands = std::max(islands, i + 1);
  if (islands == 0) return;
  std::vector<uint32_t> parent = islandsWithTexels(atlas, face_island, islands);
  const auto islandOf = [&](uint32_t face) -> int32_t {
    const int32_t i = face_island[face];
    return i < 0 ? -1 : int32_t(find(parent, uint32_t(i)));
  };

  // New charts: every chart in order, a block replaced by its islands in order of their first
  // element; the elements in that order (Morton order kept within each chart).
  std::vector<Chart> charts;
  std::vector<AtlasChartPlacement> placement;
  std::vector<int32_t> chart_of_old(nc, -1), chart_of_island(size_t(islands), -1);
  std::vector<uint32_t> order;
  order.reserve(ne);
  std::vector<uint32_t> element_chart(ne);
  for (size_t c = 0; c < nc; ++c) {
    const AtlasChartPlacement& pl = atlas.placement[c];
    const uint32_t first = pl.first_element, end = pl.first_element + pl.element_count;
    if (atlas.charts.charts[c].asset_block < 0) {
      chart_of_old[c] = int32_t(charts.size());
      AtlasChartPlacement moved = pl;
      moved.first_element = uint32_t(order.size());
      for (uint32_t e = first; e < end; ++e) {
        element_chart[e] = uint32_t(charts.size());
        order.push_back(e);
      }
      charts.push_back(atlas.charts.charts[c]);
      placement.push_back(moved);
      continue;
    }
    std::vector<int32_t> seen;
    for (uint32_t e = first; e < end; ++e) {
      const int32_t i = islandOf(atlas.element_face[e]);
      if (std::find(seen.begin(), seen.end(), i) == seen.end()) seen.push_back(i);
    }
    for (int32_t i : seen) {
      chart_of_island[size_t(i)] = int32_t(charts.size());
      AtlasChartPlacement island_pl = pl;
      island_pl.first_element = uint32_t(order.size());
      for (uint32_t e = first; e < end; ++e) {
        if (islandOf(atlas.element_face[e]) != i) continue;
        element_chart[e] = uint32_t(charts.size());
        order.push_back(e);
      }
      island_pl.element_count = uint32_t(order.size()) - island_pl.first_element;
      Chart island;
      island.asset_block = atlas.charts.charts[c].asset_block;
      for (uint32_t f : atlas.charts.charts[c].faces) {
        if (islandOf(f) != i) continue;
        island.faces.push_back(f);
      }
      charts.push_back(std::move(island));
      placement.push_back(island_pl);
    }
  }
  // Per face.
  for (size_t f = 0; f < atlas.faces.size(); ++f) {
    const int32_t c = atlas.charts.face_chart[f];
    if (c < 0) continue;
    if (atlas.charts.charts[size_t(c)].asset_block < 0) {
      atlas.charts.face_chart[f] = chart_of_old[size_t(c)];
    } else {
      const int32_t i = islandOf(uint32_t(f));
      atlas.charts.face_chart[f] = i >= 0 ? chart_of_island[size_t(i)] : -1;
    }
  }
  // Per texel.
  for (size_t t = 0; t < atlas.texel_chart.size(); ++t) {
    const int32_t c = atlas.texel_chart[t];
    if (c < 0) continue;
    if (atlas.texel_element[t] >= 0) {
      atlas.texel_chart[t] = int32_t(element_chart[size_t(atlas.texel_element[t])]);
    } else {
      const int32_t f = atlas.texel_face[t];
      atlas.texel_chart[t] = f >= 0 ? atlas.charts.face_chart[size_t(f)] : -1;
    }
  }
  permuteElements(atlas, order, std::move(element_chart));
  // Island charts' areas and normals: their elements'.
  for (size_t k = 0; k < ne; ++k) {
    Chart& chart = charts[atlas.element_chart[k]];
    if (chart.asset_block < 0) continue;
    chart.area += atlas.element_area[k];
    chart.normal += atlas.element_normal[k] * atlas.element_area[k];
  }
  for (Chart& chart : charts) {
    if (chart.asset_block < 0) continue;
    const double len = glm::length(chart.normal);
    chart.normal = len > 0.0 ? chart.normal / len : glm::dvec3(0.0, 0.0, 1.0);
  }
  atlas.charts.charts = std::move(charts);
  atlas.placement = std::move(placement);
}

}  // namespace penumbra
