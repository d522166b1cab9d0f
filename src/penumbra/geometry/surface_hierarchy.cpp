#include "penumbra/geometry/surface_hierarchy.h"

#include "penumbra/core/check.h"
#include "penumbra/core/parallel.h"

#include <glm/geometric.hpp>
#include <glm/vec4.hpp>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <queue>

namespace penumbra {

SurfaceHierarchy SurfaceHierarchy::build(const ChartAtlas& atlas) {
  SurfaceHierarchy h;
  const size_t n = atlas.elementCount();
  ClusterLevel base;
  base.first.resize(n + 1);
  base.parent.assign(n, 0);
  base.chart = atlas.element_chart;
  base.lo.resize(n);
  base.area = atlas.element_area;
  base.position = atlas.element_position;
  base.normal = atlas.element_normal;
  base.flatness.assign(n, 1.0);
  for (size_t e = 0; e < n; ++e) {
    base.first[e] = uint32_t(e);
    base.lo[e] = atlas.texelOf(e);
  }
  base.first[n] = uint32_t(n);
  base.hi = base.lo;
  h.levels_.push_back(std::move(base));

  const size_t charts = atlas.chartCount();
  h.roots_.assign(charts, ClusterRef{0, 0});
  std::vector<uint32_t> clusters_of_chart(charts, 0);
  // Roots, found level by level: a chart's root is the first level where it has one cluster.
  std::vector<bool> rooted(charts, false);
  auto markRoots = [&](uint32_t level) {
    const ClusterLevel& lv = h.levels_[level];
    std::fill(clusters_of_chart.begin(), clusters_of_chart.end(), 0u);
    for (uint32_t c : lv.chart) ++clusters_of_chart[c];
    for (uint32_t k = 0; k < lv.size(); ++k) {
      const uint32_t c = lv.chart[k];
      if (!rooted[c] && clusters_of_chart[c] == 1) {
        rooted[c] = true;
        h.roots_[c] = ClusterRef{level, k};
      }
    }
  };
  markRoots(0);

  for (uint32_t level = 1; std::find(rooted.begin(), rooted.end(), false) != rooted.end();
       ++level) {
    PENUMBRA_CHECK_MSG(level < 32, "hierarchy deeper than 31 levels");
    ClusterLevel& below = h.levels_[level - 1];
    ClusterLevel up;
    up.first.push_back(0);
    for (uint32_t k = 0; k < below.size();) {
      const uint32_t chart = below.chart[k];
      const glm::ivec2 origin = atlas.placement[chart].origin;
      const glm::ivec2 key = (below.lo[k] - origin) >> int(level);
      uint32_t j = k;
      glm::dvec3 pos(0.0), nrm(0.0);
      double area = 0.0;
      glm::ivec2 lo(std::numeric_limits<int>::max()), hi(std::numeric_limits<int>::min());
      const uint32_t index = uint32_t(up.size());
      up.child_first.push_back(k);
      while (j < below.size() && below.chart[j] == chart &&
             (below.lo[j] - origin) >> int(level) == key) {
        pos += below.position[j] * below.area[j];
        nrm += below.normal[j] * below.area[j] * below.flatness[j];
        area += below.area[j];
        lo = glm::min(lo, below.lo[j]);
        hi = glm::max(hi, below.hi[j]);
        below.parent[j] = index;
        ++j;
      }
      up.first.push_back(below.first[j]);
      up.chart.push_back(chart);
      up.lo.push_back(lo);
      up.hi.push_back(hi);
      up.area.push_back(area);
      up.position.push_back(area > 0.0 ? pos / area : below.position[k]);
      const double len = glm::length(nrm);
      up.normal.push_back(len > 0.0 ? nrm / len : below.normal[k]);
      up.flatness.push_back(area > 0.0 ? len / area : 1.0);
      k = j;
    }
    up.child_first.push_back(uint32_t(below.size()));
    up.parent.assign(up.size(), 0);
    h.levels_.push_back(std::move(up));
    markRoots(level);
  }
  ClusterLevel& top = h.levels_.back();
  for (uint32_t k = 0; k < top.size(); ++k) top.parent[k] = k;
  return h;
}

std::vector<ClusterRef> SurfaceHierarchy::children(ClusterRef c) const {
  std::vector<ClusterRef> out;
  if (c.level == 0) return out;
  const ClusterLevel& lv = levels_[c.level];
  for (uint32_t k = lv.child_first[c.index]; k < lv.child_first[c.index + 1]; ++k) {
    out.push_back(ClusterRef{c.level - 1, k});
  }
  return out;
}

std::vector<ClusterRef> SurfaceHierarchy::cut(size_t n) const {
  // Descends single-child links: the same elements, one level finer.
  auto settle = [&](ClusterRef c) {
    while (c.level > 0) {
      const ClusterLevel& lv = levels_[c.level];
      if (lv.child_first[c.index + 1] - lv.child_first[c.index] != 1) break;
      c = ClusterRef{c.level - 1, lv.child_first[c.index]};
    }
    return c;
  };
  auto area = [&](ClusterRef c) { return levels_[c.level].area[c.index]; };
  auto larger = [&](ClusterRef a, ClusterRef b) {
    const double aa = area(a), ab = area(b);
    if (aa != ab) return aa < ab;
    return elementBegin(a) > elementBegin(b);  // ties: earlier elements first
  };
  std::priority_queue<ClusterRef, std::vector<ClusterRef>, decltype(larger)> open(larger);
  std::vector<ClusterRef> done;
  for (const ClusterRef& r : roots_) {
    const ClusterRef c = settle(r);
    (c.level == 0 ? done.push_back(c) : open.push(c));
  }
  while (!open.empty() && open.size() + done.size() < n) {
    const ClusterRef c = open.top();
    open.pop();
    const ClusterLevel& lv = levels_[c.level];
    for (uint32_t k = lv.child_first[c.index]; k < lv.child_first[c.index + 1]; ++k) {
      const ClusterRef s = settle(ClusterRef{c.level - 1, k});
      (s.level == 0 ? done.push_back(s) : open.push(s));
    }
  }
  while (!open.empty()) {
    done.push_back(open.top());
    open.pop();
  }
  std::sort(done.begin(), done.end(),
            [&](ClusterRef a, ClusterRef b) { return elementBegin(a) < elementBegin(b); });
  return done;
}

std::vector<glm::dvec3> SurfaceHierarchy::interpolate(const ChartAtlas& atlas,
                                                      std::span<const ClusterRef> cut,
                                                      std::span<const glm::dvec3> values) const {
  PENUMBRA_CHECK(values.size() == cut.size());
  const size_t n = atlas.elementCount();
  // Each element's cut cluster.
  std::vector<uint32_t> owner(n, UINT32_MAX);
  for (size_t k = 0; k < cut.size(); ++k) {
    for (uint32_t e = elementBegin(cut[k]); e < elementEnd(cut[k]); ++e) owner[e] = uint32_t(k);
  }
  std::vector<glm::dvec3> out(n, glm::dvec3(0.0));
  parallelRange(atlas.chartCount(), 1, [&](size_t c_begin, size_t c_end) {
    // Summed-area tables of (A v, A) over the chart's bounding box, with a zero row and column.
    std::vector<glm::dvec4> sat;
    for (size_t c = c_begin; c < c_end; ++c) {
      const AtlasChartPlacement& pl = atlas.placement[c];
      if (pl.element_count == 0) continue;
      const int w = pl.size.x, h = pl.size.y;
      const size_t stride = size_t(w) + 1;
      sat.assign(stride * (size_t(h) + 1), glm::dvec4(0.0));
      auto at = [&](int x, int y) -> glm::dvec4& { return sat[size_t(y) * stride + size_t(x)]; };
      const uint32_t first = pl.first_element, last = pl.first_element + pl.element_count;
      for (uint32_t e = first; e < last; ++e) {
        PENUMBRA_CHECK(owner[e] != UINT32_MAX);
        const glm::ivec2 t = atlas.texelOf(e) - pl.origin;
        const double a = atlas.element_area[e];
        at(t.x + 1, t.y + 1) = glm::dvec4(values[owner[e]] * a, a);
      }
      for (int y = 1; y <= h; ++y) {
        for (int x = 1; x <= w; ++x) at(x, y) += at(x - 1, y) + at(x, y - 1) - at(x - 1, y - 1);
      }
      // Sum over texels [x0, x1] x [y0, y1] (clamped to the box; empty when x0 > x1).
      auto box = [&](int x0, int y0, int x1, int y1) {
        x0 = std::max(x0, 0);
        y0 = std::max(y0, 0);
        x1 = std::min(x1, w - 1);
        y1 = std::min(y1, h - 1);
        if (x0 > x1 || y0 > y1) return glm::dvec4(0.0);
        return at(x1 + 1, y1 + 1) - at(x0, y1 + 1) - at(x1 + 1, y0) + at(x0, y0);
      };
      for (uint32_t e = first; e < last; ++e) {
        // A box of the cluster's width s centred on the texel's centre: texels t - s/2 ..
        // t + s/2, the two end ones weighted by 1/2 along each axis, i.e. the mean of the four
        // boxes (outer or inner along x) x (outer or inner along y). s is sqrt of the cluster's
        // element count (2^l for a full block of level l), not 2^l itself: a block cut short by
        // its chart's edge holds fewer elements and stays at a coarser level than its full
        // neighbours, and a window of its level's size would jump there (visible bands along
        // the edges of walls).
        const uint32_t count = elementEnd(cut[owner[e]]) - elementBegin(cut[owner[e]]);
        const int r = int(std::lround(0.5 * std::sqrt(double(count))));
        if (count <= 1 || r == 0) {
          out[e] = values[owner[e]];
          continue;
        }
        const glm::ivec2 t = atlas.texelOf(e) - pl.origin;
        const glm::dvec4 sum = box(t.x - r, t.y - r, t.x + r, t.y + r) +
                               box(t.x - r + 1, t.y - r, t.x + r - 1, t.y + r) +
                               box(t.x - r, t.y - r + 1, t.x + r, t.y + r - 1) +
                               box(t.x - r + 1, t.y - r + 1, t.x + r - 1, t.y + r - 1);
        out[e] = sum.w > 0.0 ? glm::dvec3(sum) / sum.w : values[owner[e]];
      }
    }
  });
  return out;
}

}  // namespace penumbra
