#include "penumbra/subsurface/sss_links.h"

#include "penumbra/core/check.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <utility>

namespace penumbra {

namespace {

// The texel's steps along atlas x and y on the surface: the affine map from the face's texel
// coordinates to its positions, P(t) = P0 + [a b] (t - t0).
void texelAxes(const RadiositySurface& s, uint32_t element, glm::dvec3& a, glm::dvec3& b) {
  const ChartAtlas& atlas = s.atlas;
  const uint32_t face = atlas.element_face[element];
  const glm::uvec3 tri = s.flat.triangles[atlas.faces[face].triangle];
  const glm::dvec3 p0(s.flat.positions[tri.x]), p1(s.flat.positions[tri.y]),
      p2(s.flat.positions[tri.z]);
  const glm::dvec2 t0 = atlas.corner_texel[3 * size_t(face)],
                   t1 = atlas.corner_texel[3 * size_t(face) + 1],
                   t2 = atlas.corner_texel[3 * size_t(face) + 2];
  const glm::dvec2 u = t1 - t0, v = t2 - t0;
  const double det = u.x * v.y - u.y * v.x;
  if (std::abs(det) < 1e-12) {
    a = b = glm::dvec3(0.0);
    return;
  }
  // [p1 - p0, p2 - p0] = [a b] [u v]  =>  [a b] = [p1 - p0, p2 - p0] [u v]^-1.
  const glm::dvec3 e1 = p1 - p0, e2 = p2 - p0;
  a = (e1 * v.y - e2 * u.y) / det;
  b = (e2 * u.x - e1 * v.x) / det;
}

// Objects: one per translucent material that has elements. Fills t.object_material; returns
// each element's object (-1: opaque).
std::vector<int32_t> elementObjects(const RadiositySurface& surface,
                                    std::span<const Material> materials, SssTree& t) {
  std::map<uint32_t, int32_t> object_of_material;
  std::vector<int32_t> element_object(surface.elementCount(), -1);
  for (size_t e = 0; e < surface.elementCount(); ++e) {
    const uint32_t m = surface.material[e];
    if (!materials[m].subsurface) continue;
    auto [it, added] = object_of_material.try_emplace(m, int32_t(t.object_material.size()));
    if (added) t.object_material.push_back(m);
    element_object[e] = it->second;
  }
  return element_object;
}

// Hierarchy nodes, level by level.
void addHierarchyNodes(const RadiositySurface& surface, const std::vector<int32_t>& element_object,
                       SssTree& t) {
  const SurfaceHierarchy& h = surface.hierarchy;
  const size_t elements = surface.elementCount();
  t.level_offset.push_back(0);
  for (size_t l = 0; l < h.levelCount(); ++l) {
    t.level_offset.push_back(t.level_offset.back() + uint32_t(h.level(l).size()));
  }
  const size_t hier_nodes = t.level_offset.back();
  t.position.resize(hier_nodes);
  t.area.resize(hier_nodes);
  t.radius.resize(hier_nodes);
  t.object.resize(hier_nodes);
  t.axis_x.resize(elements);
  t.axis_y.resize(elements);
  parallelRange(elements, 4096, [&](size_t begin, size_t end) {
    for (size_t e = begin; e < end; ++e) texelAxes(surface, uint32_t(e), t.axis_x[e], t.axis_y[e]);
  });
  for (size_t l = 0; l < h.levelCount(); ++l) {
    const ClusterLevel& lv = h.level(l);
    for (size_t k = 0; k < lv.size(); ++k) {
      const size_t n = t.level_offset[l] + k;
      t.position[n] = lv.position[k];
      t.area[n] = lv.area[k];
      t.object[n] = element_object[lv.first[k]];
      if (l == 0) {
        // Half the texel's diagonal on the surface.
        t.radius[n] = 0.5 * (glm::length(t.axis_x[k]) + glm::length(t.axis_y[k]));
        continue;
      }
      double r = 0.0;
      for (uint32_t c = lv.child_first[k]; c < lv.child_first[k + 1]; ++c) {
        const size_t cn = t.level_offset[l - 1] + c;
        r = std::max(r, glm::length(t.position[cn] - t.position[n]) + t.radius[cn]);
      }
      t.radius[n] = r;
    }
  }
}

// The node standing for cluster `index` of `level`: the cluster itself, or the last cluster of the
// chain of single children it heads.
uint32_t settledNode(const SurfaceHierarchy& h, const SssTree& t, uint32_t level, uint32_t index) {
  while (level > 0) {
    const ClusterLevel& lv = h.level(level);
    if (lv.child_first[index + 1] - lv.child_first[index] != 1) break;
    index = lv.child_first[index];
    --level;
  }
  return t.level_offset[level] + index;
}

// Children, skipping single-child chains.
void linkHierarchyChildren(const SurfaceHierarchy& h, SssTree& t) {
  t.child_first.assign(1, 0);
  for (size_t l = 0; l < h.levelCount(); ++l) {
    const ClusterLevel& lv = h.level(l);
    for (size_t k = 0; k < lv.size(); ++k) {
      if (l > 0) {
        for (uint32_t c = lv.child_first[k]; c < lv.child_first[k + 1]; ++c) {
          t.child_index.push_back(settledNode(h, t, uint32_t(l - 1), c));
        }
      }
      t.child_first.push_back(uint32_t(t.child_index.size()));
    }
  }
}

// A top-tree node appended after all others; returns its index.
uint32_t addTopNode(SssTree& t, const glm::dvec3& p, double a, double r, int32_t object,
                    std::span<const uint32_t> kids) {
  t.position.push_back(p);
  t.area.push_back(a);
  t.radius.push_back(r);
  t.object.push_back(object);
  for (uint32_t k : kids) t.child_index.push_back(k);
  t.child_first.push_back(uint32_t(t.child_index.size()));
  return uint32_t(t.position.size() - 1);
}

// The top tree over `nodes`: split at the median along the widest axis of their positions,
// children first; returns its root.
uint32_t splitTopTree(SssTree& t, std::span<uint32_t> nodes, int32_t object) {
  if (nodes.size() == 1) return nodes[0];
  glm::dvec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  for (uint32_t n : nodes) {
    lo = glm::min(lo, t.position[n]);
    hi = glm::max(hi, t.position[n]);
  }
  const glm::dvec3 extent = hi - lo;
  const int axis =
      extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
  const size_t mid = nodes.size() / 2;
  std::nth_element(
      nodes.begin(), nodes.begin() + std::ptrdiff_t(mid), nodes.end(),
      [&](uint32_t a, uint32_t b) { return t.position[a][axis] < t.position[b][axis]; });
  const uint32_t left = splitTopTree(t, nodes.subspan(0, mid), object);
  const uint32_t right = splitTopTree(t, nodes.subspan(mid), object);
  const double a = t.area[left] + t.area[right];
  const glm::dvec3 p = (t.position[left] * t.area[left] + t.position[right] * t.area[right]) / a;
  const double r = std::max(glm::length(t.position[left] - p) + t.radius[left],
                            glm::length(t.position[right] - p) + t.radius[right]);
  const uint32_t kids[2] = {left, right};
  return addTopNode(t, p, a, r, object, kids);
}

// Top trees: median splits of each object's chart roots.
void addTopTrees(const SurfaceHierarchy& h, SssTree& t) {
  std::vector<std::vector<uint32_t>> roots(t.object_material.size());
  for (uint32_t c = 0; c < h.chartCount(); ++c) {
    const ClusterRef r = h.root(c);
    const uint32_t node = settledNode(h, t, r.level, r.index);
    if (t.object[node] >= 0) roots[size_t(t.object[node])].push_back(node);
  }
  for (size_t o = 0; o < roots.size(); ++o) {
    t.object_root.push_back(splitTopTree(t, roots[o], int32_t(o)));
  }
}

// The children's second moments about each node, inverted once for the per-frame gradients.
// Children of a surface node lie near a plane (or a line), so M is singular across it: the
// Tikhonov term keeps the inverse finite there, where the moments of the irradiance vanish too.
void invertMoments(SssTree& t) {
  t.moment_inverse.assign(t.nodeCount(), glm::mat3(0.0f));
  parallelRange(t.nodeCount(), 4096, [&](size_t begin, size_t end) {
    for (size_t n = begin; n < end; ++n) {
      if (t.children(uint32_t(n)).empty()) continue;
      glm::dmat3 m(0.0);
      for (uint32_t c : t.children(uint32_t(n))) {
        const glm::dvec3 d = t.position[c] - t.position[n];
        m += t.area[c] * glm::outerProduct(d, d);
      }
      const double trace = m[0][0] + m[1][1] + m[2][2];
      if (!(trace > 0.0)) continue;
      m += glm::dmat3(1e-3 * trace);
      t.moment_inverse[n] = glm::mat3(glm::inverse(m));
    }
  });
}

}  // namespace

SssTree buildSssTree(const RadiositySurface& surface, std::span<const Material> materials) {
  SssTree t;
  const std::vector<int32_t> element_object = elementObjects(surface, materials, t);
  addHierarchyNodes(surface, element_object, t);
  linkHierarchyChildren(surface.hierarchy, t);
  addTopTrees(surface.hierarchy, t);
  invertMoments(t);
  return t;
}

std::vector<Dipole> objectMedia(const SssTree& tree, std::span<const Material> materials) {
  std::vector<Dipole> media;
  for (uint32_t m : tree.object_material) {
    const Subsurface& s = *materials[m].subsurface;
    media.emplace_back(s.sigma_s_prime, s.sigma_a, s.eta);
  }
  return media;
}

namespace {

// The integral of R_d over texel square j (centre c, sides a and b: the parallelogram
// c + s a + t b, |s|, |t| <= 1/2) seen from point p, in polar coordinates about p in the square's
// plane: int_0^2pi (W(r1(theta)) - W(r0(theta))) / (2 pi) dtheta, with W(r) = int_0^r R_d 2 pi r dr
// in closed form (DipoleChannel::reflectanceWithin) and [r0, r1] where the ray from p in
// direction theta crosses the square (r0 = 0 from inside). A point at height h off the plane
// sees R_d(sqrt(r^2 + h^2)), whose integral over the disc of radius r is W(sqrt(r^2 + h^2)) -
// W(h) (substitute u^2 = r^2 + h^2). Exact in r however sharply R_d peaks within a texel (a
// point quadrature is not: a medium whose diffusion length is a texel or less puts most of R_d
// within the nearest quadrature point's cell); the angle by the midpoint rule on kAngles
// directions.
constexpr int kAngles = 32;
glm::dvec3 squareIntegral(const Dipole& medium, const glm::dvec3& p, const glm::dvec3& c,
                          const glm::dvec3& a, const glm::dvec3& b) {
  // An orthonormal basis of the plane, and the square's sides and p in it.
  const double la = glm::length(a);
  if (!(la > 0.0)) return glm::dvec3(0.0);
  const glm::dvec3 e1 = a / la;
  glm::dvec3 e2 = b - glm::dot(b, e1) * e1;
  const double l2 = glm::length(e2);
  if (!(l2 > 0.0)) return glm::dvec3(0.0);
  e2 /= l2;
  // [a b] in the basis is [[la, b1], [0, b2]]; (s, t) of a plane point (x, y) by its inverse.
  const double b1 = glm::dot(b, e1), b2 = l2;
  const glm::dvec3 q = p - c;
  const double x = glm::dot(q, e1), y = glm::dot(q, e2);
  const double h2 = std::max(0.0, glm::dot(q, q) - x * x - y * y);
  const double s0 = (x - b1 * y / b2) / la, t0 = y / b2;
  glm::dvec3 sum(0.0);
  for (int k = 0; k < kAngles; ++k) {
    const double theta = (k + 0.5) * (2.0 * std::numbers::pi / kAngles);
    const double dx = std::cos(theta), dy = std::sin(theta);
    const double ds = (dx - b1 * dy / b2) / la, dt = dy / b2;
    // Slabs |s0 + r ds| <= 1/2 and |t0 + r dt| <= 1/2 for r >= 0.
    double r0 = 0.0, r1 = std::numeric_limits<double>::infinity();
    bool empty = false;
    for (const auto& [o, d] : {std::pair{s0, ds}, std::pair{t0, dt}}) {
      if (std::abs(d) < 1e-300) {
        if (std::abs(o) > 0.5) empty = true;
        continue;
      }
      double lo = (-0.5 - o) / d, hi = (0.5 - o) / d;
      if (lo > hi) std::swap(lo, hi);
      r0 = std::max(r0, lo);
      r1 = std::min(r1, hi);
    }
    if (empty || !(r1 > r0)) continue;
    for (int ch = 0; ch < 3; ++ch) {
      const DipoleChannel& dc = medium.channel[ch];
      sum[ch] += dc.reflectanceWithin(std::sqrt(r1 * r1 + h2)) -
                 dc.reflectanceWithin(std::sqrt(r0 * r0 + h2));
    }
  }
  return sum / double(kAngles);
}

// Eq. 10 between two texel squares: the mean over m x m points p of square i of R_d
// integrated over square j from p (squareIntegral), times the share of square j its element
// covers (a texel on a chart's border holds only part of a face; the rest of its square belongs
// to the neighbouring chart's texels, which must not count it twice).
glm::dvec3 texelPairFactor(const SssTree& t, const Dipole& medium, uint32_t i, uint32_t j, int m) {
  const double square = glm::length(glm::cross(t.axis_x[j], t.axis_y[j]));
  const double covered = square > 0.0 ? std::min(1.0, t.area[j] / square) : 0.0;
  glm::dvec3 sum(0.0);
  for (int yi = 0; yi < m; ++yi) {
    for (int xi = 0; xi < m; ++xi) {
      const glm::dvec3 p = t.position[i] + ((xi + 0.5) / m - 0.5) * t.axis_x[i] +
                           ((yi + 0.5) / m - 0.5) * t.axis_y[i];
      sum += squareIntegral(medium, p, t.position[j], t.axis_x[j], t.axis_y[j]);
    }
  }
  return sum * (covered / double(m * m));
}

// Eq. 10 between two texel squares further apart by an m x m grid of points on each:
// (1 / A_i) sum_p sum_q (A_i / m^2) (A_j / m^2) R_d(|p - q|).
glm::dvec3 texelPointPairFactor(const SssTree& t, const Dipole& medium, uint32_t i, uint32_t j,
                                int m) {
  glm::dvec3 sum(0.0);
  for (int yi = 0; yi < m; ++yi) {
    for (int xi = 0; xi < m; ++xi) {
      const glm::dvec3 p = t.position[i] + ((xi + 0.5) / m - 0.5) * t.axis_x[i] +
                           ((yi + 0.5) / m - 0.5) * t.axis_y[i];
      for (int yj = 0; yj < m; ++yj) {
        for (int xj = 0; xj < m; ++xj) {
          const glm::dvec3 q = t.position[j] + ((xj + 0.5) / m - 0.5) * t.axis_x[j] +
                               ((yj + 0.5) / m - 0.5) * t.axis_y[j];
          sum += medium.reflectance(glm::length(p - q));
        }
      }
    }
  }
  return sum * (t.area[j] / double(m * m * m * m));
}

}  // namespace

namespace {

// throughputFactor with every node's value kept for the element being linked: a near node's
// factor is the sum of its children's, which the queue then needs again when it refines it.
// Alongside, the first moment of the throughput (summed over RGB) over the node's points: a near
// node's is its children's sum, a far node's (point form) its factor at its position.
class MemoThroughput {
 public:
  struct Value {
    glm::dvec3 f;
    glm::dvec3 moment;
  };
  explicit MemoThroughput(const SssTree& t)
      : t_(t), stamp_(t.nodeCount(), 0), value_(t.nodeCount()) {}
  void start(uint32_t element, const Dipole* medium) {
    element_ = element;
    medium_ = medium;
    if (++current_ == 0) {  // wrapped: forget everything
      std::fill(stamp_.begin(), stamp_.end(), 0u);
      current_ = 1;
    }
  }
  const Value& operator()(uint32_t node) {
    if (stamp_[node] == current_) return value_[node];
    const double d = glm::length(t_.position[node] - t_.position[element_]);
    const bool near = d < kNearFactor * (t_.radius[element_] + t_.radius[node]);
    Value v{glm::dvec3(0.0), glm::dvec3(0.0)};
    if (node < t_.elementCount() || !near) {
      v.f = throughputFactor(t_, *medium_, element_, node);
      v.moment = (v.f.x + v.f.y + v.f.z) * t_.position[node];
    } else {
      for (uint32_t c : t_.children(node)) {
        const Value& cv = (*this)(c);
        v.f += cv.f;
        v.moment += cv.moment;
      }
    }
    stamp_[node] = current_;
    value_[node] = v;
    return value_[node];
  }

 private:
  const SssTree& t_;
  std::vector<uint32_t> stamp_;
  std::vector<Value> value_;
  uint32_t current_ = 0;
  uint32_t element_ = 0;
  const Dipole* medium_ = nullptr;
};

}  // namespace

glm::dvec3 throughputFactor(const SssTree& t, const Dipole& medium, uint32_t element,
                            uint32_t node) {
  const double d = glm::length(t.position[node] - t.position[element]);
  const bool near = d < kNearFactor * (t.radius[element] + t.radius[node]);
  if (node < t.elementCount()) {
    if (node == element) return texelPairFactor(t, medium, element, node, 4);
    // Touching texels (within about two texels): R_d may peak inside them, so integrate it.
    if (d < kTouchFactor * (t.radius[element] + t.radius[node])) {
      return texelPairFactor(t, medium, element, node, 2);
    }
    if (near) return texelPointPairFactor(t, medium, element, node, 2);
    return t.area[node] * medium.reflectance(d);
  }
  if (!near) return t.area[node] * medium.reflectance(d);
  glm::dvec3 sum(0.0);
  for (uint32_t c : t.children(node)) sum += throughputFactor(t, medium, element, c);
  return sum;
}

namespace {

// Non-adaptive: each object's nodes at the level (or its charts' roots below it).
std::vector<std::vector<uint32_t>> nodesAtLevel(const SssTree& t, int requested_level) {
  std::vector<std::vector<uint32_t>> fixed(t.objectCount());
  const uint32_t level =
      std::min<uint32_t>(uint32_t(requested_level), uint32_t(t.level_offset.size() - 2));
  for (size_t o = 0; o < t.objectCount(); ++o) {
    std::vector<uint32_t> stack = {t.object_root[o]};
    while (!stack.empty()) {
      const uint32_t n = stack.back();
      stack.pop_back();
      // Hierarchy nodes at or below the level stop the descent; top nodes always descend.
      const bool hierarchy = n < t.level_offset.back();
      const bool at_or_below = hierarchy && n < t.level_offset[level + 1];
      if (at_or_below || t.children(n).empty()) {
        fixed[o].push_back(n);
        continue;
      }
      for (uint32_t c : t.children(n)) stack.push_back(c);
    }
  }
  return fixed;
}

// Element e's link slots in SssLinks.
struct LinkSlots {
  uint32_t* node;
  glm::vec3* factor;
  glm::vec3* offset;

  LinkSlots(SssLinks& links, size_t e)
      : node(links.node.data() + e * links.per_element),
        factor(links.factor.data() + e * links.per_element),
        offset(links.offset.data() + e * links.per_element) {}
  // Slot k: a link to `node` with factor f, read at the F-weighted centroid (moment / F).
  void write(const SssTree& t, size_t k, uint32_t n, const glm::dvec3& f,
             const glm::dvec3& moment) {
    node[k] = n;
    factor[k] = glm::vec3(f);
    const double w = f.x + f.y + f.z;
    if (w > 0.0) offset[k] = glm::vec3(moment / w - t.position[n]);
  }
};

// A node on the refinement queue: its key, factor and moment.
struct LinkCandidate {
  double key;
  uint32_t node;
  glm::dvec3 f;
  glm::dvec3 moment;
};

// The element's links by refining its object's top tree (`throughput` started for it);
// heap and leaves are scratch.
void refineLinks(const SssTree& t, uint32_t root, uint32_t per_element, MemoThroughput& throughput,
                 std::vector<LinkCandidate>& heap, std::vector<LinkCandidate>& leaves,
                 LinkSlots& out) {
  const auto less = [](const LinkCandidate& a, const LinkCandidate& b) { return a.key < b.key; };
  heap.clear();
  leaves.clear();
  // The queue is ordered by factor times radius (a near node's factor is the sum of its
  // children's, kept for when the queue refines it). Nodes that hold less than `negligible`
  // of the element's whole throughput (the far side of the object, met on the way down its
  // top tree) take no link of their own: their factors go to one remainder link to the
  // root, read at their F-weighted centroid (for uniform light the sum is exact), and the
  // other L - 1 links refine the rest. The share scales as 1 / L^2: few links cannot afford
  // to spend themselves on the far side, many can. 0.6 / L^2 is the best of 0.1, 0.25, 0.6
  // and 1 on the bunny against the all-pairs gather at 4,652 and 25,071 elements (tests/
  // subsurface/sss_links_test.cpp).
  const double negligible = 0.6 / (double(per_element) * double(per_element));
  const MemoThroughput::Value total = throughput(root);
  const double cut = per_element > 1 ? negligible * (total.f.x + total.f.y + total.f.z) : 0.0;
  glm::dvec3 remainder(0.0), remainder_moment(0.0);
  auto push = [&](uint32_t n) {
    const MemoThroughput::Value& v = throughput(n);
    const double sum = v.f.x + v.f.y + v.f.z;
    if (sum < cut) {
      remainder += v.f;
      remainder_moment += v.moment;
      return;
    }
    heap.push_back({sum * t.radius[n], n, v.f, v.moment});
    std::push_heap(heap.begin(), heap.end(), less);
  };
  heap.push_back(
      {(total.f.x + total.f.y + total.f.z) * t.radius[root], root, total.f, total.moment});
  const size_t cap = per_element > 1 ? per_element - 1 : 1;
  while (!heap.empty() && heap.size() + leaves.size() < cap) {
    std::pop_heap(heap.begin(), heap.end(), less);
    const LinkCandidate c = heap.back();
    heap.pop_back();
    const std::span<const uint32_t> kids = t.children(c.node);
    if (kids.empty()) {
      leaves.push_back(c);
      continue;
    }
    if (heap.size() + leaves.size() + kids.size() > cap) {
      heap.push_back(c);
      std::push_heap(heap.begin(), heap.end(), less);
      break;
    }
    for (uint32_t k : kids) push(k);
  }
  size_t k = 0;
  for (const auto* list : {&heap, &leaves}) {
    for (const LinkCandidate& c : *list) out.write(t, k++, c.node, c.f, c.moment);
  }
  if (remainder != glm::dvec3(0.0)) out.write(t, k, root, remainder, remainder_moment);
}

}  // namespace

SssLinks buildSssLinks(const SssTree& t, std::span<const Dipole> media,
                       const SssLinkOptions& options, const std::function<void(size_t)>& progress) {
  const Timer timer;
  SssLinks links;
  const size_t elements = t.elementCount();
  std::vector<std::vector<uint32_t>> fixed;
  if (options.level >= 0) {
    fixed = nodesAtLevel(t, options.level);
    for (const auto& f : fixed) links.per_element = std::max(links.per_element, uint32_t(f.size()));
  } else {
    PENUMBRA_CHECK(options.links >= 1);
    links.per_element = uint32_t(options.links);
  }
  links.node.assign(elements * links.per_element, 0);
  links.factor.assign(elements * links.per_element, glm::vec3(0.0f));
  links.offset.assign(elements * links.per_element, glm::vec3(0.0f));
  std::atomic<size_t> done{0};

  parallelRange(elements, 256, [&](size_t begin, size_t end) {
    std::vector<LinkCandidate> heap, leaves;
    MemoThroughput throughput(t);
    for (size_t e = begin; e < end; ++e) {
      const int32_t o = t.object[e];
      if (o < 0) continue;
      const Dipole& medium = media[size_t(o)];
      LinkSlots out(links, e);
      throughput.start(uint32_t(e), &medium);
      if (options.level >= 0) {
        const std::vector<uint32_t>& list = fixed[size_t(o)];
        for (size_t k = 0; k < list.size(); ++k) {
          const MemoThroughput::Value& v = throughput(list[k]);
          out.write(t, k, list[k], v.f, v.moment);
        }
        continue;
      }
      refineLinks(t, t.object_root[size_t(o)], links.per_element, throughput, heap, leaves, out);
    }
    const size_t now = done += end - begin;
    if (progress) progress(now);
  });
  links.seconds = timer.seconds();
  return links;
}

std::vector<glm::vec3> nodeMeans(const SssTree& t, std::span<const glm::vec3> element_values) {
  std::vector<glm::vec3> v(t.nodeCount(), glm::vec3(0.0f));
  const size_t elements = t.elementCount();
  std::copy(element_values.begin(), element_values.begin() + std::ptrdiff_t(elements), v.begin());
  // Level by level (children before parents), then the top trees (built children first).
  // Every node's children (settled or not) cover its elements exactly once.
  for (size_t n = elements; n < t.nodeCount(); ++n) {
    glm::dvec3 sum(0.0);
    for (uint32_t c : t.children(n)) sum += glm::dvec3(v[c]) * t.area[c];
    v[n] = t.area[n] > 0.0 ? glm::vec3(sum / t.area[n]) : glm::vec3(0.0f);
  }
  return v;
}

SssNodeIrradiance mipMapIrradiance(const SssTree& t, std::span<const glm::vec3> element_values) {
  SssNodeIrradiance m;
  m.mean = nodeMeans(t, element_values);
  m.gradient.assign(t.nodeCount(), glm::mat3(0.0f));
  parallelRange(t.nodeCount() - t.elementCount(), 4096, [&](size_t begin, size_t end) {
    for (size_t n = t.elementCount() + begin; n < t.elementCount() + end; ++n) {
      // Least squares: G minimises sum_c a_c |E_c - E_n - G d_c|^2, G = S M^-1 with
      // S = sum_c a_c (E_c - E_n) d_c^T.
      glm::mat3 s(0.0f);
      for (uint32_t c : t.children(uint32_t(n))) {
        const glm::vec3 d(t.position[c] - t.position[n]);
        s += float(t.area[c]) * glm::outerProduct(m.mean[c] - m.mean[n], d);
      }
      m.gradient[n] = s * t.moment_inverse[n];
    }
  });
  return m;
}

void gatherScattered(const SssLinks& links, const SssNodeIrradiance& node_irradiance,
                     std::span<glm::vec3> scattered) {
  const size_t per = links.per_element;
  const glm::vec3* mean = node_irradiance.mean.data();
  const glm::mat3* gradient = node_irradiance.gradient.data();
  parallelRange(scattered.size(), 4096, [&](size_t begin, size_t end) {
    for (size_t e = begin; e < end; ++e) {
      glm::vec3 b(0.0f);
      for (size_t k = e * per; k < (e + 1) * per; ++k) {
        const uint32_t n = links.node[k];
        const glm::vec3 value = glm::max(mean[n] + gradient[n] * links.offset[k], glm::vec3(0.0f));
        b += links.factor[k] * value;
      }
      scattered[e] = b;
    }
  });
}

std::vector<glm::vec3> gatherAllPairs(const SssTree& t, std::span<const Dipole> media,
                                      std::span<const glm::vec3> element_irradiance) {
  const size_t elements = t.elementCount();
  std::vector<std::vector<uint32_t>> members(t.objectCount());
  for (size_t e = 0; e < elements; ++e) {
    if (t.object[e] >= 0) members[size_t(t.object[e])].push_back(uint32_t(e));
  }
  std::vector<glm::vec3> out(elements, glm::vec3(0.0f));
  parallelRange(elements, 64, [&](size_t begin, size_t end) {
    for (size_t e = begin; e < end; ++e) {
      if (t.object[e] < 0) continue;
      const Dipole& medium = media[size_t(t.object[e])];
      glm::dvec3 b(0.0);
      for (uint32_t j : members[size_t(t.object[e])]) {
        b += throughputFactor(t, medium, uint32_t(e), j) * glm::dvec3(element_irradiance[j]);
      }
      out[e] = glm::vec3(b);
    }
  });
  return out;
}

}  // namespace penumbra
