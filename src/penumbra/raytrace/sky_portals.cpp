#include "penumbra/raytrace/sky_portals.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>

namespace penumbra {

SkyPortals::SkyPortals(const std::optional<Sky>& sky, const std::vector<Opening>& openings) {
  if (!sky) return;
  for (const Opening& o : openings) {
    for (size_t k = 1; k + 1 < o.corners.size(); ++k) {
      const glm::vec3 a(o.corners[0]), b(o.corners[k]), c(o.corners[k + 1]);
      const glm::vec3 cr = glm::cross(b - a, c - a);
      const float len = glm::length(cr);
      if (!(len > 0.0f)) continue;
      tris_.push_back({a, b, c, cr / len, 0.5f * len});
      total_area_ += 0.5 * double(len);
      cdf_.push_back(total_area_);
    }
  }
}

glm::vec3 SkyPortals::point(float u1, float u2, glm::vec3& normal) const {
  // The triangle by area, u1 remapped within it.
  const double at = double(u1) * total_area_;
  const size_t k = std::min(size_t(std::upper_bound(cdf_.begin(), cdf_.end(), at) - cdf_.begin()),
                            tris_.size() - 1);
  const double lo = k > 0 ? cdf_[k - 1] : 0.0;
  const float within = std::clamp(float((at - lo) / double(tris_[k].area)), 0.0f, 1.0f - 0x1p-24f);
  const Tri& t = tris_[k];
  const glm::vec2 b = sampleTriangleBarycentrics(within, u2);
  normal = t.normal;
  return t.a + b.x * (t.b - t.a) + b.y * (t.c - t.a);
}

float SkyPortals::pdf(const glm::vec3& x, const glm::vec3& w) const {
  if (!active()) return 0.0f;
  double sum = 0.0;
  const glm::dvec3 o(x), d(w);
  for (const Tri& t : tris_) {
    // Moller-Trumbore in double precision: the crossing's distance and the cosine there.
    const glm::dvec3 e1 = glm::dvec3(t.b - t.a), e2 = glm::dvec3(t.c - t.a);
    const glm::dvec3 pv = glm::cross(d, e2);
    const double det = glm::dot(e1, pv);
    if (std::abs(det) < 1e-300) continue;
    const glm::dvec3 tv = o - glm::dvec3(t.a);
    const double u = glm::dot(tv, pv) / det;
    if (u < 0.0 || u > 1.0) continue;
    const glm::dvec3 qv = glm::cross(tv, e1);
    const double v = glm::dot(d, qv) / det;
    if (v < 0.0 || u + v > 1.0) continue;
    const double dist = glm::dot(e2, qv) / det;
    if (!(dist > 0.0)) continue;
    const double cos_y = std::abs(glm::dot(d, glm::dvec3(t.normal)));
    if (!(cos_y > 0.0)) continue;
    sum += dist * dist / cos_y;
  }
  return float(sum / total_area_);
}

}  // namespace penumbra
