#include "penumbra/render/direct_emitters.h"

#include "penumbra/core/color.h"
#include "penumbra/kernels/form_factor.h"
#include "penumbra/kernels/sampling.h"

#include <glm/geometric.hpp>

#include <cmath>
#include <numbers>

namespace penumbra {

namespace {

glm::vec2 jittered(uint32_t i, uint32_t side, Rng& rng) {
  const float u1 = rng.uniform(), u2 = rng.uniform();
  return jitteredCell(i, side, u1, u2);
}

glm::dvec3 pointOn(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, glm::vec2 u) {
  return pointOnTriangle(a, b, c, u.x, u.y);
}

// A shadow ray from `from` to just short of `to`.
bool blocked(const RayEngine& engine, const glm::dvec3& from, const glm::dvec3& to) {
  return engine.occluded(Ray{glm::vec3(from), 1e-4f, glm::vec3(to - from), 1.0f - 1e-4f});
}

}  // namespace

AreaEmitters::AreaEmitters(const Scene& scene, const FlatTriangles& flat) {
  handled_.assign(flat.triangles.size(), 0);
  std::vector<Emitter> found;
  std::vector<uint32_t> ids;
  for (size_t t = 0; t < flat.triangles.size(); ++t) {
    const Material& m = scene.materials[flat.material_ids[t]];
    if (!m.isEmissive() || m.unlit || m.emission_texture || m.coverage_texture) continue;
    const glm::uvec3 tri = flat.triangles[t];
    Emitter e;
    e.a = glm::dvec3(flat.positions[tri.x]);
    e.b = glm::dvec3(flat.positions[tri.y]);
    e.c = glm::dvec3(flat.positions[tri.z]);
    const glm::dvec3 cr = glm::cross(e.b - e.a, e.c - e.a);
    const double len = glm::length(cr);
    if (!(len > 0.0)) continue;  // degenerate: never hit, emits nothing
    e.normal = cr / len;
    e.area = 0.5 * len;
    e.radiance = glm::dvec3(m.emission);
    e.luminance = luminance(e.radiance);
    found.push_back(e);
    ids.push_back(uint32_t(t));
  }
  if (found.size() > kMaxTriangles) return;  // left to the gather
  emitters_ = std::move(found);
  for (uint32_t t : ids) handled_[t] = 1;
}

glm::dvec3 AreaEmitters::irradiance(const RayEngine& engine, const glm::dvec3& x,
                                    const glm::dvec3& n, double lift, Rng& rng,
                                    uint64_t& rays) const {
  struct Term {
    const Emitter* e;
    double f;       // the unoccluded form factor
    double weight;  // its share of the luminance, for allocating rays
    double k = 0.0, kv = 0.0;
  };
  thread_local std::vector<Term> terms;
  terms.clear();
  double total_weight = 0.0;
  for (const Emitter& e : emitters_) {
    if (!(glm::dot(e.normal, x - e.a) > 0.0)) continue;  // x behind the emitting face
    const glm::dvec3 poly[3] = {e.a, e.b, e.c};
    const double f = pointToPolygonFormFactor(x, n, poly, 3);
    if (!(f > 0.0)) continue;
    terms.push_back({&e, f, e.luminance * f});
    total_weight += e.luminance * f;
  }
  if (terms.empty()) return glm::dvec3(0.0);
  const glm::dvec3 from = x + lift * n;
  int traced = 0, free = 0;
  // `count` rays spread over the terms by systematic sampling of their weights (each term gets
  // the floor or ceiling of its share), stratified on each triangle.
  const auto pass = [&](int count, bool detect) {
    const double shift = rng.uniform();
    double cumulative = 0.0;
    for (Term& term : terms) {
      const SystematicShare share =
          systematicShare(cumulative, cumulative + term.weight, total_weight, count, shift);
      cumulative += term.weight;
      if (share.samples == 0) continue;
      const uint32_t side = share.side;
      for (uint32_t i = 0; i < side * side; ++i) {
        const glm::dvec3 y = pointOn(term.e->a, term.e->b, term.e->c, jittered(i, side, rng));
        const glm::dvec3 d = y - x;
        const double r2 = glm::dot(d, d);
        const double k = glm::dot(n, d) * -glm::dot(term.e->normal, d) / (r2 * r2);
        if (!(k > 0.0)) continue;  // below the horizon: outside the clipped polygon
        const bool v = !blocked(engine, from, y);
        ++traced;
        free += v;
        term.k += k;
        term.kv += v ? k : 0.0;
      }
      if (!detect) continue;
      // The first pass also looks at the triangle's corners and edge midpoints (pulled 0.1%
      // towards its centroid): an occluder that hides a sliver along an edge, which the
      // interior samples can miss, is found there and sends the point to the refined pass.
      const glm::dvec3 centre = (term.e->a + term.e->b + term.e->c) / 3.0;
      const glm::dvec3 rim[6] = {term.e->a,
                                 term.e->b,
                                 term.e->c,
                                 0.5 * (term.e->a + term.e->b),
                                 0.5 * (term.e->b + term.e->c),
                                 0.5 * (term.e->c + term.e->a)};
      for (const glm::dvec3& q : rim) {
        const glm::dvec3 y = q + 1e-3 * (centre - q);
        if (!(glm::dot(n, y - x) > 0.0)) continue;
        ++traced;
        free += !blocked(engine, from, y);
      }
    }
  };
  pass(kFirstRays, true);
  rays += uint64_t(traced);
  glm::dvec3 e(0.0);
  if (traced > 0 && free == 0) return e;  // wholly hidden
  if (free < traced) {
    const int before = traced;
    pass(kPenumbraRays, false);
    rays += uint64_t(traced - before);
  }
  double k_all = 0.0, kv_all = 0.0;
  for (const Term& t : terms) {
    k_all += t.k;
    kv_all += t.kv;
  }
  const double v_all = k_all > 0.0 ? kv_all / k_all : 1.0;
  for (const Term& t : terms) {
    const double v = traced == free ? 1.0 : t.k > 0.0 ? t.kv / t.k : v_all;
    e += std::numbers::pi * t.f * v * t.e->radiance;
  }
  return e;
}

glm::dvec3 AreaEmitters::cylindricalIrradiance(const RayEngine& engine, const glm::dvec3& x,
                                               const glm::dvec3& up, double lift, Rng& rng,
                                               uint64_t& rays) const {
  constexpr uint32_t kSide = 8, kPoints = kSide * kSide;
  glm::dvec3 e(0.0);
  const glm::dvec3 from = x + lift * up;
  for (const Emitter& em : emitters_) {
    if (!(glm::dot(em.normal, x - em.a) > 0.0)) continue;
    double sum = 0.0;
    for (uint32_t i = 0; i < kPoints; ++i) {
      const glm::dvec3 y = pointOn(em.a, em.b, em.c, jittered(i, kSide, rng));
      const glm::dvec3 d = y - x;
      const double r2 = glm::dot(d, d), r = std::sqrt(r2);
      const double cos_e = -glm::dot(em.normal, d) / r;
      if (!(cos_e > 0.0)) continue;
      const double c = glm::dot(up, d) / r;
      const double sin_a = std::sqrt(std::max(0.0, 1.0 - c * c));
      ++rays;
      if (blocked(engine, from, y)) continue;
      sum += sin_a * cos_e / r2;
    }
    e += em.radiance * (sum * em.area / double(kPoints) / std::numbers::pi);
  }
  return e;
}

}  // namespace penumbra
