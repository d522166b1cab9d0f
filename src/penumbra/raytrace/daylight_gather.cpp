#include "penumbra/raytrace/daylight_gather.h"

#include "penumbra/kernels/form_factor.h"
#include "penumbra/kernels/sampling.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace penumbra {

OpeningLight::OpeningLight(const Scene& scene) {
  sky_ = scene.sky;
  openings_ = scene.openings;
  for (size_t i = 0; i < openings_.size(); ++i) {
    const Opening& o = openings_[i];
    for (size_t k = 1; k + 1 < o.corners.size(); ++k) {
      Tri t{o.corners[0], o.corners[k], o.corners[k + 1], glm::dvec3(0.0), 0.0, i};
      const glm::dvec3 cr = glm::cross(t.b - t.a, t.c - t.a);
      const double len = glm::length(cr);
      if (!(len > 0.0)) continue;
      t.normal = cr / len;
      t.area = 0.5 * len;
      triangles_.push_back(t);
      area_cdf_.push_back((area_cdf_.empty() ? 0.0 : area_cdf_.back()) + t.area);
    }
    glm::dvec3 n(0.0);
    for (size_t k = 1; k + 1 < o.corners.size(); ++k) {
      n += glm::cross(o.corners[k] - o.corners[0], o.corners[k + 1] - o.corners[0]);
    }
    unit_normals_.push_back(glm::length(n) > 0.0 ? glm::normalize(n) : n);
  }
}

glm::dvec3 OpeningLight::portalPoint(float u1, float u2) const {
  // The triangle by area, u1 remapped within it.
  const double at = double(u1) * area_cdf_.back();
  const size_t k =
      std::min(size_t(std::upper_bound(area_cdf_.begin(), area_cdf_.end(), at) - area_cdf_.begin()),
               triangles_.size() - 1);
  const double lo = k > 0 ? area_cdf_[k - 1] : 0.0;
  const Tri& t = triangles_[k];
  const float within = std::clamp(float((at - lo) / t.area), 0.0f, 1.0f - 0x1p-24f);
  return pointOnTriangle(t.a, t.b, t.c, within, u2);
}

double OpeningLight::portalPdf(const glm::dvec3& x, const glm::dvec3& w) const {
  if (!active()) return 0.0;
  double sum = 0.0;
  for (size_t i = 0; i < openings_.size(); ++i) {
    const double t = crossOpening(openings_[i], x, w);
    if (!(t > 0.0)) continue;
    const double cos_y = std::fabs(glm::dot(unit_normals_[i], w));
    if (cos_y > 0.0) sum += t * t / cos_y;
  }
  return sum / area_cdf_.back();
}

bool OpeningLight::crosses(const Ray& ray, float tmax) const {
  const glm::dvec3 o(ray.origin), d(ray.dir);
  for (const Opening& op : openings_) {
    const double t = crossOpening(op, o, d);
    if (t > 0.0 && t < double(tmax)) return true;
  }
  return false;
}

DaylightIrradiance OpeningLight::irradiance(const RayEngine& engine, const glm::dvec3& x,
                                            const glm::dvec3& n, double lift, int samples,
                                            bool cylindrical, Rng& rng, const Outside& outside,
                                            uint64_t& rays) const {
  DaylightIrradiance out;
  if (!active()) return out;
  struct Term {
    const Tri* t;
    double f;  // planar: the unoccluded form factor; cylindrical: a solid-angle weight
    double k = 0.0;
    glm::dvec3 sky{0.0}, ext{0.0};
  };
  thread_local std::vector<Term> terms;
  terms.clear();
  double total = 0.0;
  for (const Tri& t : triangles_) {
    double f = 0.0;
    if (cylindrical) {
      const glm::dvec3 d = (t.a + t.b + t.c) / 3.0 - x;
      const double r2 = glm::dot(d, d);
      f = t.area * std::fabs(glm::dot(t.normal, d)) / (r2 * std::sqrt(r2) + 1e-300);
    } else {
      const glm::dvec3 poly[3] = {t.a, t.b, t.c};
      f = pointToPolygonFormFactor(x, n, poly, 3);
    }
    if (!(f > 0.0)) continue;
    terms.push_back({&t, f});
    total += f;
  }
  if (terms.empty()) return out;
  const glm::dvec3 from = x + lift * n;
  const double shift = rng.uniform();
  double cumulative = 0.0;
  for (Term& term : terms) {
    const SystematicShare share =
        systematicShare(cumulative, cumulative + term.f, total, samples, shift);
    cumulative += term.f;
    if (share.samples == 0) continue;
    const uint32_t side = share.side;
    const Tri& t = *term.t;
    double plain = 0.0;  // cylindrical: the plain area estimate's weight
    for (uint32_t i = 0; i < side * side; ++i) {
      const float u1 = rng.uniform(), u2 = rng.uniform();
      const glm::vec2 u = jitteredCell(i, side, u1, u2);
      const glm::dvec3 y = pointOnTriangle(t.a, t.b, t.c, u.x, u.y);
      const glm::dvec3 d = y - x;
      const double r2 = glm::dot(d, d), r = std::sqrt(r2);
      const glm::dvec3 dir = d / r;
      const double cos_y = std::fabs(glm::dot(t.normal, dir));
      double k;
      if (cylindrical) {
        const double c = glm::dot(n, dir);
        k = std::sqrt(std::max(0.0, 1.0 - c * c)) * cos_y / (std::numbers::pi * r2);
      } else {
        k = glm::dot(n, dir) * cos_y / r2;
      }
      plain += 1.0;
      if (!(k > 0.0)) continue;
      term.k += k;
      ++rays;
      if (engine.occluded(Ray{glm::vec3(from), 1e-4f, glm::vec3(y - from), 1.0f - 1e-4f})) continue;
      const double tau = openings_[t.opening].transmittanceAt(cos_y);
      // Onwards from the opening: an outside surface, or the sky and the ground.
      const Ray onwards{glm::vec3(y), float(1e-4 * (1.0 + r)), glm::vec3(dir),
                        std::numeric_limits<float>::max()};
      ++rays;
      const Hit hit = engine.intersect(onwards);
      if (hit.hit()) {
        term.ext += k * tau * glm::dvec3(outside(onwards, hit, rng));
      } else if (dir.y >= 0.0) {
        term.sky += k * tau * glm::dvec3(sky_->radiance(dir));
      } else {
        term.ext += k * tau * glm::dvec3(sky_->radiance(dir));
      }
    }
    if (cylindrical) {
      // Plain Monte Carlo over the triangle's area.
      const double w = plain > 0.0 ? t.area / plain : 0.0;
      out.sky += w * term.sky;
      out.external += w * term.ext;
    } else if (term.k > 0.0) {
      const double w = std::numbers::pi * term.f / term.k;
      out.sky += w * term.sky;
      out.external += w * term.ext;
    }
  }
  return out;
}

}  // namespace penumbra
