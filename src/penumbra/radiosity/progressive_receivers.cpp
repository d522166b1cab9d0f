#include "penumbra/radiosity/progressive_receivers.h"

#include "penumbra/core/check.h"
#include "penumbra/radiosity/radiosity_surface.h"

#include <fmt/format.h>
#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <algorithm>
#include <limits>

namespace penumbra {

Status checkSubdivisionOptions(const SubdivisionOptions& o) {
  if (!(o.boundary_low >= 0.0 && o.boundary_low <= o.boundary_high && o.boundary_high <= 1.0)) {
    return inputError("", "subdivision", "the thresholds need 0 <= b_l <= b_u <= 1");
  }
  if (!(o.min_share >= 0.0 && o.min_share <= 1.0)) {
    return inputError("", "subdivision", "the minimum share must be in [0, 1]");
  }
  if (o.finest_level < 0 || o.finest_level > 16) {
    return inputError("", "subdivision", "the finest level must be in [0, 16]");
  }
  return {};
}

ProgressiveReceivers ProgressiveReceivers::uniform(const RadiositySurface& surface, int level) {
  const SurfaceHierarchy& h = surface.hierarchy;
  std::vector<ClusterRef> cut;
  for (uint32_t c = 0; c < h.chartCount(); ++c) {
    std::vector<ClusterRef> stack = {h.root(c)};
    while (!stack.empty()) {
      const ClusterRef k = stack.back();
      stack.pop_back();
      if (int(k.level) <= level) {
        cut.push_back(k);
        continue;
      }
      const std::vector<ClusterRef> children = h.children(k);
      stack.insert(stack.end(), children.rbegin(), children.rend());
    }
  }
  ProgressiveReceivers r;
  r.assign(surface, std::move(cut));
  return r;
}

Expected<ProgressiveReceivers> ProgressiveReceivers::fromElementLevels(
    const RadiositySurface& surface, std::span<const uint8_t> levels) {
  const SurfaceHierarchy& h = surface.hierarchy;
  const size_t n = surface.elementCount();
  if (levels.size() != n) {
    return inputError("", "receivers",
                      fmt::format("{} receiver levels for {} elements", levels.size(), n));
  }
  std::vector<ClusterRef> cut;
  for (size_t e = 0; e < n;) {
    if (levels[e] >= h.levelCount()) {
      return inputError("", "receivers",
                        fmt::format("element {}: level {} above the hierarchy's {}", e,
                                    int(levels[e]), h.levelCount() - 1));
    }
    ClusterRef c{0, uint32_t(e)};
    while (c.level < levels[e]) c = ClusterRef{c.level + 1, h.level(c.level).parent[c.index]};
    if (h.elementBegin(c) != e) {
      return inputError("", "receivers", fmt::format("element {}: not a cut of the hierarchy", e));
    }
    for (uint32_t m = h.elementBegin(c); m < h.elementEnd(c); ++m) {
      if (levels[m] != levels[e]) {
        return inputError("", "receivers",
                          fmt::format("element {}: not a cut of the hierarchy", m));
      }
    }
    cut.push_back(c);
    e = h.elementEnd(c);
  }
  ProgressiveReceivers r;
  r.assign(surface, std::move(cut));
  return r;
}

void ProgressiveReceivers::assign(const RadiositySurface& surface, std::vector<ClusterRef> cut) {
  const SurfaceHierarchy& h = surface.hierarchy;
  std::sort(cut.begin(), cut.end(),
            [&](ClusterRef a, ClusterRef b) { return h.elementBegin(a) < h.elementBegin(b); });
  cut_ = std::move(cut);
  const size_t m = cut_.size();
  position_.resize(m);
  normal_.resize(m);
  shading_normal_.resize(m);
  chart_.resize(m);
  face_.resize(m);
  texel_element_.resize(m);
  barycentric_.resize(m);
  owner_.assign(surface.elementCount(), 0);
  per_element_ = true;
  for (size_t k = 0; k < m; ++k) {
    const ClusterRef c = cut_[k];
    const ClusterLevel& lv = h.level(c.level);
    position_[k] = lv.position[c.index];
    normal_[k] = lv.normal[c.index];
    chart_[k] = lv.chart[c.index];
    const uint32_t first = h.elementBegin(c), last = h.elementEnd(c);
    per_element_ = per_element_ && last - first == 1;
    glm::dvec3 ns(0.0);
    for (uint32_t e = first; e < last; ++e) {
      owner_[e] = uint32_t(k);
      ns += surface.shading_normal[e] * surface.atlas.element_area[e];
    }
    const double len = glm::length(ns);
    shading_normal_[k] = last - first == 1 ? surface.shading_normal[first]
                         : len > 0.0       ? ns / len
                                           : normal_[k];
    if (last - first == 1) {
      position_[k] = surface.atlas.element_position[first];
      face_[k] = surface.atlas.element_face[first];
      barycentric_[k] = surface.atlas.element_barycentric[first];
      texel_element_[k] = first;
      continue;
    }
    placeOnSurface(surface, k, first, last);
  }
}

void ProgressiveReceivers::placeOnSurface(const RadiositySurface& surface, size_t k, uint32_t first,
                                          uint32_t last) {
  // The centroid projected onto each candidate face's triangle: the first face that holds it
  // (barycentrics in [0, 1]), else the nearest clamped point.
  const ChartAtlas& atlas = surface.atlas;
  const glm::dvec3 c = position_[k];
  double best = std::numeric_limits<double>::infinity();
  for (uint32_t e = first; e < last && best > 0.0; ++e) {
    for (uint32_t i = atlas.element_face_first[e]; i < atlas.element_face_first[e + 1]; ++i) {
      const uint32_t f = atlas.element_faces[i];
      const glm::uvec3 tri = surface.flat.triangles[atlas.faces[f].triangle];
      const glm::dvec3 p0(surface.flat.positions[tri.x]), p1(surface.flat.positions[tri.y]),
          p2(surface.flat.positions[tri.z]);
      const glm::dvec3 u = p1 - p0, v = p2 - p0, w = c - p0;
      const double uu = glm::dot(u, u), uv = glm::dot(u, v), vv = glm::dot(v, v);
      const double det = uu * vv - uv * uv;
      if (!(det > 0.0)) continue;
      const double wu = glm::dot(w, u), wv = glm::dot(w, v);
      glm::dvec2 b((vv * wu - uv * wv) / det, (uu * wv - uv * wu) / det);
      const bool inside = b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0;
      if (!inside) b = glm::dvec2(clampBarycentric(glm::vec2(b)));
      const glm::dvec3 q = p0 + u * b.x + v * b.y;
      const double miss = inside ? 0.0 : glm::length(q - c) + 1e-300;
      if (miss < best) {
        best = miss;
        face_[k] = f;
        barycentric_[k] = glm::vec2(b);
        position_[k] = q;
      }
    }
  }
  double nearest = std::numeric_limits<double>::infinity();
  for (uint32_t e = first; e < last; ++e) {
    const glm::dvec3 d = atlas.element_position[e] - position_[k];
    if (glm::dot(d, d) < nearest) {
      nearest = glm::dot(d, d);
      texel_element_[k] = e;
    }
  }
}

std::vector<uint8_t> ProgressiveReceivers::elementLevels() const {
  std::vector<uint8_t> levels(owner_.size());
  for (size_t e = 0; e < owner_.size(); ++e) levels[e] = uint8_t(cut_[owner_[e]].level);
  return levels;
}

uint32_t ProgressiveReceivers::subdivide(const RadiositySurface& surface,
                                         std::span<const uint16_t> counted,
                                         std::span<const uint16_t> visible,
                                         std::span<const float> share,
                                         const SubdivisionOptions& options) {
  const SurfaceHierarchy& h = surface.hierarchy;
  const size_t n = surface.elementCount();
  PENUMBRA_CHECK(counted.size() == n && visible.size() == n && share.size() == n);
  // Prefix sums: a cluster's n_r, n_v and shares over its contiguous element range.
  std::vector<uint64_t> sum_r(n + 1, 0), sum_v(n + 1, 0);
  std::vector<double> sum_share(n + 1, 0.0);
  for (size_t e = 0; e < n; ++e) {
    sum_r[e + 1] = sum_r[e] + counted[e];
    sum_v[e + 1] = sum_v[e] + visible[e];
    sum_share[e + 1] = sum_share[e] + double(share[e]);
  }
  // Sec. 4: n_r != n_v means a shadow boundary; b_l <= n_v / n_r <= b_u leaves out receivers
  // that a boundary only grazes.
  const auto boundary = [&](ClusterRef c) {
    const uint64_t nr = sum_r[h.elementEnd(c)] - sum_r[h.elementBegin(c)];
    const uint64_t nv = sum_v[h.elementEnd(c)] - sum_v[h.elementBegin(c)];
    if (nr == 0 || nv >= nr) return false;
    const double ratio = double(nv) / double(nr);
    const double mean_share =
        (sum_share[h.elementEnd(c)] - sum_share[h.elementBegin(c)]) / double(nr);
    return ratio >= options.boundary_low && ratio <= options.boundary_high &&
           mean_share >= options.min_share;
  };
  uint32_t splits = 0;
  std::vector<ClusterRef> cut;
  cut.reserve(cut_.size());
  std::vector<ClusterRef> stack;
  for (const ClusterRef r : cut_) {
    stack.assign(1, r);
    while (!stack.empty()) {
      const ClusterRef k = stack.back();
      stack.pop_back();
      if (int(k.level) <= options.finest_level || !boundary(k)) {
        cut.push_back(k);
        continue;
      }
      // Regular refinement (Baum et al.): the block's children, tested again.
      const std::vector<ClusterRef> children = h.children(k);
      if (children.size() > 1) ++splits;
      stack.insert(stack.end(), children.rbegin(), children.rend());
    }
  }
  assign(surface, std::move(cut));
  return splits + balance(surface);
}

uint32_t ProgressiveReceivers::balance(const RadiositySurface& surface) {
  const SurfaceHierarchy& h = surface.hierarchy;
  const ChartAtlas& atlas = surface.atlas;
  uint32_t splits = 0;
  std::vector<uint8_t> split;
  for (;;) {
    // A receiver marks each neighbour more than one level coarser: the receivers over the
    // texels of the ring around its block, in its chart.
    split.assign(cut_.size(), 0);
    bool any = false;
    for (size_t k = 0; k < cut_.size(); ++k) {
      const ClusterRef c = cut_[k];
      const ClusterLevel& lv = h.level(c.level);
      const glm::ivec2 lo = lv.lo[c.index] - 1, hi = lv.hi[c.index] + 1;
      const auto visit = [&](int x, int y) {
        if (x < 0 || y < 0 || x >= atlas.width || y >= atlas.height) return;
        const int32_t e = atlas.texel_element[atlas.texelIndex(x, y)];
        if (e < 0 || atlas.element_chart[size_t(e)] != chart_[k]) return;
        const uint32_t o = owner_[size_t(e)];
        if (cut_[o].level > c.level + 1 && !split[o]) {
          split[o] = 1;
          any = true;
        }
      };
      for (int x = lo.x; x <= hi.x; ++x) {
        visit(x, lo.y);
        visit(x, hi.y);
      }
      for (int y = lo.y + 1; y < hi.y; ++y) {
        visit(lo.x, y);
        visit(hi.x, y);
      }
    }
    if (!any) return splits;
    std::vector<ClusterRef> cut;
    cut.reserve(cut_.size());
    for (size_t k = 0; k < cut_.size(); ++k) {
      if (!split[k]) {
        cut.push_back(cut_[k]);
        continue;
      }
      const std::vector<ClusterRef> children = h.children(cut_[k]);
      if (children.size() > 1) ++splits;
      cut.insert(cut.end(), children.begin(), children.end());
    }
    assign(surface, std::move(cut));
  }
}

std::vector<glm::dvec3> ProgressiveReceivers::toElements(const RadiositySurface& surface,
                                                         std::vector<glm::dvec3> values) const {
  PENUMBRA_CHECK(values.size() == cut_.size());
  if (per_element_) return values;
  // The summed-area tables' differences can round below zero (by 1e-16 of a chart's sum) where
  // an irradiance is zero.
  std::vector<glm::dvec3> out = surface.hierarchy.interpolate(surface.atlas, cut_, values);
  for (glm::dvec3& v : out) v = glm::max(v, glm::dvec3(0.0));
  return out;
}

}  // namespace penumbra
