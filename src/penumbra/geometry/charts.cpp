#include "penumbra/geometry/charts.h"

#include "penumbra/core/check.h"
#include "penumbra/core/parallel.h"
#include "penumbra/geometry/weld.h"

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <glm/geometric.hpp>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <optional>
#include <queue>
#include <unordered_map>

namespace penumbra {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegree = kPi / 180.0;

// The corners of face f in its own orientation: a back face runs (0, 2, 1), so that its
// counter-clockwise side is the back. oriented[j] is the triangle corner at position j.
constexpr uint32_t kFrontOrder[3] = {0, 1, 2};
constexpr uint32_t kBackOrder[3] = {0, 2, 1};

struct FaceGeometry {
  glm::dvec3 p[3];  // oriented corners
  uint32_t v[3];    // welded vertex ids, oriented
  glm::dvec3 normal{0.0};
  glm::dvec3 centroid{0.0};
  double area = 0.0;
};

FaceGeometry faceGeometry(std::span<const glm::vec3> positions,
                          std::span<const glm::uvec3> triangles, const std::vector<uint32_t>& weld,
                          const SurfaceFace& face) {
  const glm::uvec3 tri = triangles[face.triangle];
  const uint32_t* order = face.back ? kBackOrder : kFrontOrder;
  FaceGeometry g;
  for (int j = 0; j < 3; ++j) {
    const uint32_t vi = tri[int(order[j])];
    g.p[j] = glm::dvec3(positions[vi]);
    g.v[j] = weld[vi];
  }
  const glm::dvec3 c = glm::cross(g.p[1] - g.p[0], g.p[2] - g.p[0]);
  const double len = glm::length(c);
  g.area = 0.5 * len;
  g.normal = len > 0.0 ? c / len : glm::dvec3(0.0);
  g.centroid = (g.p[0] + g.p[1] + g.p[2]) / 3.0;
  return g;
}

// Two unit vectors completing n to a right-handed frame (t x b = n).
void tangentFrame(const glm::dvec3& n, glm::dvec3& t, glm::dvec3& b) {
  const glm::dvec3 a = std::abs(n.x) < 0.6 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  t = glm::normalize(glm::cross(a, n));
  b = glm::cross(n, t);
}

// Singular value ratio s1 / s2 of the 2x2 map J = [a b; c d].
double singularRatio(double a, double b, double c, double d) {
  const double e = a * a + b * b + c * c + d * d;
  const double det = a * d - b * c;
  const double disc = std::sqrt(std::max(0.0, e * e - 4.0 * det * det));
  const double s1 = std::sqrt(0.5 * (e + disc));
  const double s2 = std::sqrt(std::max(0.0, 0.5 * (e - disc)));
  return s2 > 0.0 ? s1 / s2 : std::numeric_limits<double>::infinity();
}

// Gradients of the three barycentric (hat) functions of a face in its own plane, and its
// area: grad phi_j = rot90(p_{j+2} - p_{j+1}) / (2 A) in the frame e1 = p1 - p0, e2 = n x e1.
struct FaceGradients {
  double gx[3], gy[3];
  double area;
};
FaceGradients faceGradients(const FaceGeometry& g) {
  FaceGradients fg{};
  fg.area = g.area;
  const glm::dvec3 e1 = glm::normalize(g.p[1] - g.p[0]);
  const glm::dvec3 e2 = glm::cross(g.normal, e1);
  double x[3], y[3];
  for (int j = 0; j < 3; ++j) {
    x[j] = glm::dot(g.p[j] - g.p[0], e1);
    y[j] = glm::dot(g.p[j] - g.p[0], e2);
  }
  for (int j = 0; j < 3; ++j) {
    const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
    fg.gx[j] = -(y[j2] - y[j1]) / (2.0 * g.area);
    fg.gy[j] = (x[j2] - x[j1]) / (2.0 * g.area);
  }
  return fg;
}

// A chart's own vertices (its faces' welded vertices, numbered in order of first use) and each
// face corner's vertex: corner[3 i + j] is corner j (oriented) of the chart's face i.
struct ChartVertices {
  std::vector<glm::dvec3> position;
  std::vector<uint32_t> corner;
};

// Chart-local vertices.
ChartVertices chartVertices(const Chart& chart, const std::vector<FaceGeometry>& geo) {
  ChartVertices cv;
  std::unordered_map<uint32_t, uint32_t> local;
  cv.corner.resize(chart.faces.size() * 3);
  for (size_t i = 0; i < chart.faces.size(); ++i) {
    const FaceGeometry& g = geo[chart.faces[i]];
    for (int j = 0; j < 3; ++j) {
      auto [it, fresh] = local.emplace(g.v[j], uint32_t(cv.position.size()));
      if (fresh) cv.position.push_back(g.p[j]);
      cv.corner[3 * i + size_t(j)] = it->second;
    }
  }
  return cv;
}

// The chart's area, its area-weighted mean normal, and whether it is planar (every face within
// options.flat_deg of that normal).
void chartShape(Chart& chart, const std::vector<FaceGeometry>& geo, const ChartOptions& options) {
  glm::dvec3 sum_n(0.0);
  chart.area = 0.0;
  for (uint32_t f : chart.faces) {
    sum_n += geo[f].normal * geo[f].area;
    chart.area += geo[f].area;
  }
  chart.normal = glm::length(sum_n) > 0.0 ? glm::normalize(sum_n) : geo[chart.faces[0]].normal;
  double min_cos = 1.0;
  for (uint32_t f : chart.faces) min_cos = std::min(min_cos, glm::dot(geo[f].normal, chart.normal));
  chart.planar = min_cos >= std::cos(options.flat_deg * kDegree);
}

// Points q moved to their centroid and rotated so that their principal direction is the x axis.
void principalAlign(std::vector<glm::dvec2>& q) {
  glm::dvec2 m(0.0);
  for (const glm::dvec2& p : q) m += p;
  m /= double(q.size());
  double sxx = 0.0, syy = 0.0, sxy = 0.0;
  for (const glm::dvec2& p : q) {
    const glm::dvec2 d = p - m;
    sxx += d.x * d.x;
    syy += d.y * d.y;
    sxy += d.x * d.y;
  }
  const double angle = 0.5 * std::atan2(2.0 * sxy, sxx - syy);
  const double c = std::cos(angle), s = std::sin(angle);
  for (glm::dvec2& p : q) {
    const glm::dvec2 d = p - m;
    p = glm::dvec2(c * d.x + s * d.y, -s * d.x + c * d.y);  // rotation keeps orientation
  }
}

// Orthogonal projection onto the mean normal's plane, axes along the principal direction.
std::vector<glm::dvec2> planeProjection(const std::vector<glm::dvec3>& vp,
                                        const glm::dvec3& normal) {
  glm::dvec3 t, b;
  tangentFrame(normal, t, b);
  const size_t nv = vp.size();
  std::vector<glm::dvec2> proj(nv);
  glm::dvec2 mean(0.0);
  for (size_t v = 0; v < nv; ++v) {
    proj[v] = glm::dvec2(glm::dot(vp[v], t), glm::dot(vp[v], b));
    mean += proj[v];
  }
  mean /= double(nv);
  principalAlign(proj);
  return proj;
}

// Connected components through shared vertices (union-find): the conformal map with two pins
// is determined only on a connected chart (a split chart may fall apart).
size_t componentCount(const ChartVertices& cv) {
  const size_t nv = cv.position.size();
  std::vector<uint32_t> parent(nv);
  std::iota(parent.begin(), parent.end(), 0u);
  auto findRoot = [&](uint32_t v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  size_t components = nv;
  for (size_t i = 0; i < cv.corner.size() / 3; ++i) {
    for (int j = 1; j < 3; ++j) {
      const uint32_t ra = findRoot(cv.corner[3 * i]), rb = findRoot(cv.corner[3 * i + size_t(j)]);
      if (ra != rb) {
        parent[ra] = rb;
        --components;
      }
    }
  }
  return components;
}

// Least-squares conformal map (Levy et al. 2002): per face, the Cauchy-Riemann residuals
// u_x - v_y and u_y + v_x of the linear map, weighted by sqrt(area) (eq. 4-6), summed in
// the least-squares sense; the vertices of least and greatest projected u are pinned at
// their projected positions, which fixes translation, rotation and scale. Nothing when the
// solve fails.
std::optional<std::vector<glm::dvec2>> solveConformal(const Chart& chart,
                                                      const std::vector<FaceGeometry>& geo,
                                                      const std::vector<uint32_t>& corner,
                                                      const std::vector<glm::dvec2>& proj) {
  const uint32_t nv = uint32_t(proj.size());
  uint32_t pin0 = 0, pin1 = 0;
  for (uint32_t v = 0; v < nv; ++v) {
    if (proj[v].x < proj[pin0].x) pin0 = v;
    if (proj[v].x > proj[pin1].x) pin1 = v;
  }
  std::vector<int32_t> column(nv, -1);
  int32_t free_count = 0;
  for (uint32_t v = 0; v < nv; ++v) {
    if (v != pin0 && v != pin1) column[v] = free_count++;
  }
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(chart.faces.size() * 12);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(Eigen::Index(2 * chart.faces.size()));
  Eigen::Index row = 0;
  for (size_t i = 0; i < chart.faces.size(); ++i, row += 2) {
    const FaceGeometry& g = geo[chart.faces[i]];
    if (!(g.area > 0.0)) continue;
    const FaceGradients fg = faceGradients(g);
    const double w = std::sqrt(g.area);
    for (int j = 0; j < 3; ++j) {
      const uint32_t v = corner[3 * i + size_t(j)];
      // Row 0: gx u - gy v; row 1: gy u + gx v.
      const double a0 = w * fg.gx[j], b0 = -w * fg.gy[j];
      const double a1 = w * fg.gy[j], b1 = w * fg.gx[j];
      if (column[v] >= 0) {
        const Eigen::Index cu = 2 * column[v], cv = cu + 1;
        entries.emplace_back(row, cu, a0);
        entries.emplace_back(row, cv, b0);
        entries.emplace_back(row + 1, cu, a1);
        entries.emplace_back(row + 1, cv, b1);
      } else {
        rhs[row] -= a0 * proj[v].x + b0 * proj[v].y;
        rhs[row + 1] -= a1 * proj[v].x + b1 * proj[v].y;
      }
    }
  }
  Eigen::SparseMatrix<double> a(row, 2 * Eigen::Index(free_count));
  a.setFromTriplets(entries.begin(), entries.end());
  const Eigen::SparseMatrix<double> at = a.transpose();
  const Eigen::SparseMatrix<double> normal = at * a;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(normal);
  if (solver.info() != Eigen::Success) return std::nullopt;
  const Eigen::VectorXd x = solver.solve(at * rhs);
  if (solver.info() != Eigen::Success || !x.allFinite()) return std::nullopt;
  std::vector<glm::dvec2> lscm(nv);
  for (uint32_t v = 0; v < nv; ++v) {
    lscm[v] = column[v] < 0 ? proj[v] : glm::dvec2(x[2 * column[v]], x[2 * column[v] + 1]);
  }
  return lscm;
}

// No fold: every face keeps its orientation, and no face shrinks to nearly nothing
// (area ratio to the chart's mean above 1e-3). uv_area: the map's area.
bool foldFree(const Chart& chart, const std::vector<FaceGeometry>& geo,
              const std::vector<uint32_t>& corner, const std::vector<glm::dvec2>& lscm,
              double& uv_area) {
  bool ok = true;
  uv_area = 0.0;
  std::vector<double> face_uv(chart.faces.size(), 0.0);
  for (size_t i = 0; i < chart.faces.size() && ok; ++i) {
    if (!(geo[chart.faces[i]].area > 0.0)) continue;
    const glm::dvec2 p0 = lscm[corner[3 * i]], p1 = lscm[corner[3 * i + 1]],
                     p2 = lscm[corner[3 * i + 2]];
    const double cross = (p1.x - p0.x) * (p2.y - p0.y) - (p1.y - p0.y) * (p2.x - p0.x);
    if (!(cross > 0.0)) ok = false;
    face_uv[i] = 0.5 * cross;
    uv_area += 0.5 * cross;
  }
  for (size_t i = 0; i < chart.faces.size() && ok; ++i) {
    const double a3 = geo[chart.faces[i]].area;
    if (a3 > 0.0 && face_uv[i] / uv_area < 1e-3 * a3 / chart.area) ok = false;
  }
  return ok;
}

// The chart's map: the conformal one where it exists without folds, else the projection.
std::vector<glm::dvec2> chartMap(Chart& chart, const std::vector<FaceGeometry>& geo,
                                 const ChartVertices& cv, std::vector<glm::dvec2> proj) {
  chart.conformal = false;
  if (chart.planar || chart.faces.size() < 2 || componentCount(cv) != 1) return proj;
  std::optional<std::vector<glm::dvec2>> lscm = solveConformal(chart, geo, cv.corner, proj);
  if (!lscm) return proj;
  double uv_area = 0.0;
  if (!foldFree(chart, geo, cv.corner, *lscm, uv_area) || !(uv_area > 0.0)) return proj;
  // One texel density for the whole scene: the chart's area in the plane equals its area.
  const double s = std::sqrt(chart.area / uv_area);
  for (glm::dvec2& p : *lscm) p *= s;
  principalAlign(*lscm);
  chart.conformal = true;
  return std::move(*lscm);
}

// Corners in the triangles' own order; stretch per face.
void writeChartMap(ChartSet& set, const Chart& chart, const std::vector<FaceGeometry>& geo,
                   std::span<const SurfaceFace> faces, const std::vector<uint32_t>& corner,
                   const std::vector<glm::dvec2>& uv) {
  for (size_t i = 0; i < chart.faces.size(); ++i) {
    const uint32_t f = chart.faces[i];
    const uint32_t* order = faces[f].back ? kBackOrder : kFrontOrder;
    for (int j = 0; j < 3; ++j) set.uv[3 * size_t(f) + order[j]] = uv[corner[3 * i + size_t(j)]];
    const FaceGeometry& g = geo[f];
    if (!(g.area > 0.0)) {
      set.stretch[f] = 1.0;
      continue;
    }
    const FaceGradients fg = faceGradients(g);
    double j00 = 0.0, j01 = 0.0, j10 = 0.0, j11 = 0.0;
    for (int j = 0; j < 3; ++j) {
      const glm::dvec2 q = uv[corner[3 * i + size_t(j)]];
      j00 += q.x * fg.gx[j];
      j01 += q.x * fg.gy[j];
      j10 += q.y * fg.gx[j];
      j11 += q.y * fg.gy[j];
    }
    set.stretch[f] = singularRatio(j00, j01, j10, j11);
  }
}

// Parameterises chart `chart` of `set` (its faces' geometry in `geo`): fills set.uv, set.stretch
// and the chart's planar / conformal flags.
void parameterise(ChartSet& set, Chart& chart, const std::vector<FaceGeometry>& geo,
                  std::span<const SurfaceFace> faces, const ChartOptions& options) {
  const ChartVertices cv = chartVertices(chart, geo);
  chartShape(chart, geo, options);
  const std::vector<glm::dvec2> uv =
      chartMap(chart, geo, cv, planeProjection(cv.position, chart.normal));
  writeChartMap(set, chart, geo, faces, cv.corner, uv);
}

struct Adjacency {
  std::vector<uint32_t> first;  // size faces + 1
  std::vector<uint32_t> face;
};

// Faces sharing an edge (by welded vertex ids) across which one chart may grow: the same
// material and normals within the crease angle. Nothing else can join a chart, so growth,
// relaxation and merging see only these edges (the two sides of a two-sided surface, facing
// opposite ways, are never adjacent, so they fall into separate components).
Adjacency adjacency(const std::vector<FaceGeometry>& geo, std::span<const SurfaceFace> faces,
                    std::span<const uint32_t> material_ids, double cos_crease) {
  auto joinable = [&](uint32_t a, uint32_t b) {
    return material_ids[faces[a].triangle] == material_ids[faces[b].triangle] &&
           glm::dot(geo[a].normal, geo[b].normal) >= cos_crease;
  };
  struct EdgeFace {
    uint64_t key;
    uint32_t face;
  };
  std::vector<EdgeFace> edges;
  edges.reserve(geo.size() * 3);
  for (uint32_t f = 0; f < geo.size(); ++f) {
    if (!(geo[f].area > 0.0)) continue;
    for (int j = 0; j < 3; ++j) {
      const uint64_t a = geo[f].v[j], b = geo[f].v[(j + 1) % 3];
      edges.push_back({(std::min(a, b) << 32) | std::max(a, b), f});
    }
  }
  std::sort(edges.begin(), edges.end(), [](const EdgeFace& x, const EdgeFace& y) {
    return x.key != y.key ? x.key < y.key : x.face < y.face;
  });
  std::vector<std::pair<uint32_t, uint32_t>> pairs;
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j].key == edges[i].key) ++j;
    // Faces on one edge; more than two on a non-manifold edge, all mutually adjacent. Edges
    // shared by very many faces (a fan of coincident slivers) are left unconnected.
    if (j - i <= 8) {
      for (size_t a = i; a < j; ++a) {
        for (size_t b = a + 1; b < j; ++b) {
          if (edges[a].face == edges[b].face || !joinable(edges[a].face, edges[b].face)) continue;
          pairs.emplace_back(edges[a].face, edges[b].face);
          pairs.emplace_back(edges[b].face, edges[a].face);
        }
      }
    }
    i = j;
  }
  Adjacency adj;
  adj.first.assign(geo.size() + 1, 0);
  for (const auto& p : pairs) ++adj.first[p.first + 1];
  for (size_t f = 0; f < geo.size(); ++f) adj.first[f + 1] += adj.first[f];
  adj.face.resize(pairs.size());
  std::vector<uint32_t> next(adj.first.begin(), adj.first.end() - 1);
  for (const auto& p : pairs) adj.face[next[p.first]++] = p.second;
  return adj;
}

// Region growing leaves fragments where a scan is noisy (a spike, a crease): charts far smaller
// than the mean, each costing a border ring and padding in the atlas. Each such chart, smallest
// first, joins the adjacent chart of the same material whose mean normal is nearest its own,
// provided every face of both stays within `merge_cone_deg` of the merged mean normal (so the
// projection onto it cannot fold); set.face_chart and set.charts are rewritten.
void mergeSmallCharts(ChartSet& set, const std::vector<FaceGeometry>& geo, const Adjacency& adj,
                      std::span<const SurfaceFace> faces, std::span<const uint32_t> material_ids,
                      const ChartOptions& options) {
  const size_t nc = set.charts.size();
  if (nc < 2 || options.merge_fraction <= 0.0) return;
  std::vector<glm::dvec3> sum_n(nc, glm::dvec3(0.0));
  std::vector<double> area(nc, 0.0);
  double total = 0.0;
  for (size_t c = 0; c < nc; ++c) {
    for (uint32_t f : set.charts[c].faces) {
      sum_n[c] += geo[f].normal * geo[f].area;
      area[c] += geo[f].area;
    }
    total += area[c];
  }
  const double small = options.merge_fraction * total / double(nc);
  const double cos_merge = std::cos(options.merge_cone_deg * kDegree);
  const double cos_crease = std::cos(options.crease_deg * kDegree);
  std::vector<uint32_t> order(nc);
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(),
                   [&](uint32_t a, uint32_t b) { return area[a] < area[b]; });
  auto within = [&](uint32_t c, const glm::dvec3& axis) {
    for (uint32_t f : set.charts[c].faces) {
      if (glm::dot(geo[f].normal, axis) < cos_merge) return false;
    }
    return true;
  };
  std::vector<uint32_t> neighbours;
  for (uint32_t c : order) {
    if (set.charts[c].faces.empty() || area[c] >= small) continue;
    const uint32_t material = material_ids[faces[set.charts[c].faces[0]].triangle];
    neighbours.clear();
    for (uint32_t f : set.charts[c].faces) {
      for (uint32_t k = adj.first[f]; k < adj.first[f + 1]; ++k) {
        // Across an edge that is no crease.
        const int32_t d = set.face_chart[adj.face[k]];
        if (d >= 0 && uint32_t(d) != c &&
            glm::dot(geo[f].normal, geo[adj.face[k]].normal) >= cos_crease) {
          neighbours.push_back(uint32_t(d));
        }
      }
    }
    std::sort(neighbours.begin(), neighbours.end());
    neighbours.erase(std::unique(neighbours.begin(), neighbours.end()), neighbours.end());
    const glm::dvec3 own = glm::normalize(sum_n[c]);
    std::sort(neighbours.begin(), neighbours.end(), [&](uint32_t a, uint32_t b) {
      return glm::dot(own, glm::normalize(sum_n[a])) > glm::dot(own, glm::normalize(sum_n[b]));
    });
    for (uint32_t d : neighbours) {
      if (material_ids[faces[set.charts[d].faces[0]].triangle] != material) continue;
      const glm::dvec3 axis = glm::normalize(sum_n[c] + sum_n[d]);
      if (!within(c, axis) || !within(d, axis)) continue;
      for (uint32_t f : set.charts[c].faces) set.face_chart[f] = int32_t(d);
      set.charts[d].faces.insert(set.charts[d].faces.end(), set.charts[c].faces.begin(),
                                 set.charts[c].faces.end());
      set.charts[c].faces.clear();
      sum_n[d] += sum_n[c];
      area[d] += area[c];
      break;
    }
  }
  // Renumber the charts that are left.
  std::vector<Chart> kept;
  for (Chart& chart : set.charts) {
    if (chart.faces.empty()) continue;
    std::sort(chart.faces.begin(), chart.faces.end());
    for (uint32_t f : chart.faces) set.face_chart[f] = int32_t(kept.size());
    kept.push_back(std::move(chart));
  }
  set.charts = std::move(kept);
}

// Every face's geometry (corners welded by position).
std::vector<FaceGeometry> faceGeometries(std::span<const glm::vec3> positions,
                                         std::span<const glm::uvec3> triangles,
                                         std::span<const SurfaceFace> faces) {
  const std::vector<uint32_t> weld = weldPositions(positions);
  std::vector<FaceGeometry> geo(faces.size());
  for (size_t f = 0; f < faces.size(); ++f) {
    PENUMBRA_CHECK(faces[f].triangle < triangles.size());
    geo[f] = faceGeometry(positions, triangles, weld, faces[f]);
  }
  return geo;
}

// The faces by area, largest first (stable): the order charts are seeded in.
std::vector<uint32_t> seedOrder(const std::vector<FaceGeometry>& geo) {
  std::vector<uint32_t> seeds(geo.size());
  std::iota(seeds.begin(), seeds.end(), 0u);
  std::stable_sort(seeds.begin(), seeds.end(),
                   [&](uint32_t a, uint32_t b) { return geo[a].area > geo[b].area; });
  return seeds;
}

// Connected components of the adjacency: what one chart can span at most. Charts never cross
// them, so each component grows and relaxes on its own, in parallel, with the same result as
// one pass over all faces.
struct Components {
  std::vector<uint32_t> of;  // per face
  size_t count = 0;
};

Components adjacencyComponents(const Adjacency& adj, size_t nf) {
  Components components;
  components.of.assign(nf, UINT32_MAX);
  std::vector<uint32_t> stack;
  for (uint32_t f0 = 0; f0 < nf; ++f0) {
    if (components.of[f0] != UINT32_MAX) continue;
    const uint32_t id = uint32_t(components.count++);
    components.of[f0] = id;
    stack.push_back(f0);
    while (!stack.empty()) {
      const uint32_t f = stack.back();
      stack.pop_back();
      for (uint32_t q = adj.first[f]; q < adj.first[f + 1]; ++q) {
        const uint32_t g = adj.face[q];
        if (components.of[g] == UINT32_MAX) {
          components.of[g] = id;
          stack.push_back(g);
        }
      }
    }
  }
  return components;
}

// A face a chart may take, reached from its face `from`: cheapest first, then lowest face.
struct Candidate {
  double cost;
  uint32_t face, from;
  bool operator>(const Candidate& o) const {
    return cost != o.cost ? cost > o.cost : face > o.face;
  }
};

// What charts grow over: the faces, the edges a chart may cross, the options and the cosine of
// the cone every chart's faces stay within.
struct Growth {
  const std::vector<FaceGeometry>& geo;
  const Adjacency& adj;
  const ChartOptions& options;
  double cos_cone;
};

// Grows one chart, labelled `id` in set.face_chart, from `seed` over unassigned faces (the
// first pass, and faces that the relaxation below leaves to no chart). Touches only the seed's
// component.
void growFrom(const Growth& growth, ChartSet& set, uint32_t seed, int32_t id, Chart& chart) {
  const std::vector<FaceGeometry>& geo = growth.geo;
  const Adjacency& adj = growth.adj;
  glm::dvec3 sum_n = geo[seed].normal * geo[seed].area;
  double area = geo[seed].area;
  const glm::dvec3 origin = geo[seed].centroid;
  std::priority_queue<Candidate, std::vector<Candidate>, std::greater<>> heap;
  auto accept = [&](uint32_t f) {
    set.face_chart[f] = id;
    chart.faces.push_back(f);
    const glm::dvec3 mean = glm::normalize(sum_n);
    const double radius = std::sqrt(area / kPi);
    for (uint32_t k = adj.first[f]; k < adj.first[f + 1]; ++k) {
      const uint32_t g = adj.face[k];
      if (set.face_chart[g] >= 0) continue;
      const double cost = (1.0 - glm::dot(geo[g].normal, mean)) +
                          growth.options.compactness * glm::length(geo[g].centroid - origin) /
                              std::max(radius, 1e-30);
      heap.push({cost, g, f});
    }
  };
  accept(seed);
  while (!heap.empty()) {
    const Candidate c = heap.top();
    heap.pop();
    if (set.face_chart[c.face] >= 0) continue;
    // Material and crease rules hold for every edge of the adjacency.
    const glm::dvec3& n = geo[c.face].normal;
    if (glm::dot(n, glm::normalize(sum_n)) < growth.cos_cone) continue;
    sum_n += n * geo[c.face].area;
    area += geo[c.face].area;
    accept(c.face);
  }
}

// The first pass: a chart grown from every seed (largest face first) that no chart has taken.
void growCharts(const Growth& growth, ChartSet& set, const std::vector<uint32_t>& seeds,
                const Components& components) {
  // Each component's seeds, in the global order (largest face first).
  std::vector<std::vector<uint32_t>> component_seeds(components.count);
  for (uint32_t rank = 0; rank < seeds.size(); ++rank) {
    if (growth.geo[seeds[rank]].area > 0.0) {
      component_seeds[components.of[seeds[rank]]].push_back(rank);
    }
  }
  // Labelled by the seed's rank while components grow in parallel, then numbered in seed
  // order.
  std::vector<std::pair<uint32_t, Chart>> grown;
  std::vector<std::vector<std::pair<uint32_t, Chart>>> per_component(components.count);
  parallelRange(components.count, 1, [&](size_t b, size_t e) {
    for (size_t k = b; k < e; ++k) {
      for (uint32_t rank : component_seeds[k]) {
        if (set.face_chart[seeds[rank]] >= 0) continue;
        Chart chart;
        growFrom(growth, set, seeds[rank], int32_t(rank), chart);
        per_component[k].emplace_back(rank, std::move(chart));
      }
    }
  });
  for (auto& list : per_component) {
    for (auto& entry : list) grown.push_back(std::move(entry));
  }
  std::sort(grown.begin(), grown.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  for (auto& entry : grown) {
    for (uint32_t f : entry.second.faces) set.face_chart[f] = int32_t(set.charts.size());
    set.charts.push_back(std::move(entry.second));
  }
}

// Per chart: its mean normal, centre, radius (of the disc of its area) and its most central
// face, where the relaxation reseeds it.
struct ChartSeeds {
  std::vector<glm::dvec3> normal, centre;
  std::vector<double> radius;
  std::vector<uint32_t> seed;
};

ChartSeeds reseedCharts(const ChartSet& set, const std::vector<FaceGeometry>& geo) {
  const size_t nc = set.charts.size();
  ChartSeeds s;
  s.normal.resize(nc);
  s.centre.resize(nc);
  s.radius.resize(nc);
  s.seed.resize(nc);
  parallelRange(nc, 64, [&](size_t c_begin, size_t c_end) {
    for (size_t c = c_begin; c < c_end; ++c) {
      glm::dvec3 sn(0.0), sc(0.0);
      double area = 0.0;
      for (uint32_t f : set.charts[c].faces) {
        sn += geo[f].normal * geo[f].area;
        sc += geo[f].centroid * geo[f].area;
        area += geo[f].area;
      }
      s.normal[c] = glm::normalize(sn);
      s.centre[c] = sc / area;
      s.radius[c] = std::sqrt(area / kPi);
      double best = std::numeric_limits<double>::max();
      for (uint32_t f : set.charts[c].faces) {
        const double cost = glm::length(geo[f].centroid - s.centre[c]) / s.radius[c] +
                            2.0 * (1.0 - glm::dot(geo[f].normal, s.normal[c]));
        if (cost < best) {
          best = cost;
          s.seed[c] = f;
        }
      }
    }
  });
  return s;
}

// All charts regrown together from their seeds, each component through one priority queue;
// set.face_chart is rewritten (faces no chart reaches are left at -1).
void regrowFromSeeds(const Growth& growth, ChartSet& set, const ChartSeeds& s,
                     const Components& components) {
  const std::vector<FaceGeometry>& geo = growth.geo;
  const Adjacency& adj = growth.adj;
  const size_t nc = set.charts.size();
  std::fill(set.face_chart.begin(), set.face_chart.end(), -1);
  for (size_t c = 0; c < nc; ++c) set.face_chart[s.seed[c]] = int32_t(c);
  std::vector<std::vector<uint32_t>> component_charts(components.count);
  for (size_t c = 0; c < nc; ++c) component_charts[components.of[s.seed[c]]].push_back(uint32_t(c));
  parallelRange(components.count, 1, [&](size_t b, size_t e) {
    for (size_t k = b; k < e; ++k) {
      std::priority_queue<Candidate, std::vector<Candidate>, std::greater<>> heap;
      // The chart a candidate would join is its `from` face's, fixed when it is pushed, so
      // the cone rule is applied then (material and crease hold for every edge).
      auto push = [&](uint32_t f, int32_t c) {
        const glm::dvec3& mean = s.normal[size_t(c)];
        for (uint32_t q = adj.first[f]; q < adj.first[f + 1]; ++q) {
          const uint32_t g = adj.face[q];
          if (set.face_chart[g] >= 0) continue;
          const double facing = glm::dot(geo[g].normal, mean);
          if (facing < growth.cos_cone) continue;
          const double cost =
              glm::length(geo[g].centroid - geo[s.seed[size_t(c)]].centroid) / s.radius[size_t(c)] +
              2.0 * (1.0 - facing);
          heap.push({cost, g, f});
        }
      };
      for (uint32_t c : component_charts[k]) push(s.seed[c], int32_t(c));
      while (!heap.empty()) {
        const Candidate cand = heap.top();
        heap.pop();
        if (set.face_chart[cand.face] >= 0) continue;
        const int32_t c = set.face_chart[cand.from];
        set.face_chart[cand.face] = c;
        push(cand.face, c);
      }
    }
  });
}

// Relaxation (Lloyd iterations as in Variational Shape Approximation, Cohen-Steiner, Alliez,
// Desbrun 2004, with the compactness of D-charts): each chart is reseeded at its most central
// face and all charts regrow together from their seeds through one priority queue, cost =
// distance to the seed / the chart's radius + 2 (1 - n . the chart's mean normal), under the
// same cone, crease and material rules. Charts become compact (round rather than sprawling),
// which is what packs well.
void relaxCharts(const Growth& growth, ChartSet& set, const std::vector<uint32_t>& seeds,
                 const Components& components) {
  for (int iteration = 0; iteration < growth.options.relax_iterations; ++iteration) {
    regrowFromSeeds(growth, set, reseedCharts(set, growth.geo), components);
    for (Chart& chart : set.charts) chart.faces.clear();
    for (uint32_t f = 0; f < set.face_chart.size(); ++f) {
      if (set.face_chart[f] >= 0) set.charts[size_t(set.face_chart[f])].faces.push_back(f);
    }
    for (uint32_t s : seeds) {
      if (set.face_chart[s] < 0 && growth.geo[s].area > 0.0) {
        Chart chart;
        growFrom(growth, set, s, int32_t(set.charts.size()), chart);
        set.charts.push_back(std::move(chart));
      }
    }
  }
}

}  // namespace

ChartSet buildCharts(std::span<const glm::vec3> positions, std::span<const glm::uvec3> triangles,
                     std::span<const uint32_t> material_ids, std::span<const SurfaceFace> faces,
                     const ChartOptions& options) {
  PENUMBRA_CHECK(material_ids.size() == triangles.size());
  const std::vector<FaceGeometry> geo = faceGeometries(positions, triangles, faces);
  const size_t nf = faces.size();
  const double cos_cone = std::cos(options.max_cone_deg * kDegree);
  const double cos_crease = std::cos(options.crease_deg * kDegree);
  const Adjacency adj = adjacency(geo, faces, material_ids, cos_crease);
  ChartSet set;
  set.face_chart.assign(nf, -1);
  set.uv.assign(3 * nf, glm::dvec2(0.0));
  set.stretch.assign(nf, 1.0);
  const std::vector<uint32_t> seeds = seedOrder(geo);
  const Components components = adjacencyComponents(adj, nf);
  const Growth growth{geo, adj, options, cos_cone};

  growCharts(growth, set, seeds, components);
  relaxCharts(growth, set, seeds, components);
  for (Chart& chart : set.charts) std::sort(chart.faces.begin(), chart.faces.end());
  mergeSmallCharts(set, geo, adj, faces, material_ids, options);
  // Each chart writes only its own faces' UVs and stretch.
  parallelRange(set.charts.size(), 1, [&](size_t b, size_t e) {
    for (size_t k = b; k < e; ++k) parameterise(set, set.charts[k], geo, faces, options);
  });
  return set;
}

struct ChartSplitter::Scratch {
  std::vector<FaceGeometry> geo;  // indexed by face; only the split chart's faces are read
};

ChartSplitter::ChartSplitter(std::span<const glm::vec3> positions,
                             std::span<const glm::uvec3> triangles,
                             std::span<const SurfaceFace> faces, const ChartOptions& options)
    : positions_(positions),
      triangles_(triangles),
      faces_(faces),
      options_(options),
      weld_(weldPositions(positions)),
      scratch_(std::make_unique<Scratch>()) {}

ChartSplitter::~ChartSplitter() = default;

bool ChartSplitter::split(ChartSet& set, size_t c) {
  PENUMBRA_CHECK(c < set.charts.size());
  if (set.charts[c].faces.size() < 2) return false;
  std::vector<FaceGeometry>& geo = scratch_->geo;
  if (geo.size() < faces_.size()) geo.resize(faces_.size());
  for (uint32_t f : set.charts[c].faces)
    geo[f] = faceGeometry(positions_, triangles_, weld_, faces_[f]);
  // Faces ordered along the chart's principal direction in the plane (its u axis).
  std::vector<std::pair<double, uint32_t>> key;
  for (uint32_t f : set.charts[c].faces) {
    const double u =
        (set.uv[3 * size_t(f)].x + set.uv[3 * size_t(f) + 1].x + set.uv[3 * size_t(f) + 2].x);
    key.emplace_back(u, f);
  }
  std::sort(key.begin(), key.end());
  Chart a, b;
  for (size_t i = 0; i < key.size(); ++i)
    (i < key.size() / 2 ? a : b).faces.push_back(key[i].second);
  std::sort(a.faces.begin(), a.faces.end());
  std::sort(b.faces.begin(), b.faces.end());
  const int32_t id_b = int32_t(set.charts.size());
  for (uint32_t f : b.faces) set.face_chart[f] = id_b;
  set.charts[c] = std::move(a);
  set.charts.push_back(std::move(b));
  parameterise(set, set.charts[c], geo, faces_, options_);
  parameterise(set, set.charts.back(), geo, faces_, options_);
  return true;
}

}  // namespace penumbra
