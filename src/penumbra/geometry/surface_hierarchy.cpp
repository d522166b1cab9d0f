#include "penumbra/geometry/surface_hierarchy.h"

#include "penumbra/core/check.h"

#include <glm/geometric.hpp>

#include <algorithm>
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

}  // namespace penumbra
