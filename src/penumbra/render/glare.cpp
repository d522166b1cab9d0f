#include "penumbra/render/glare.h"

#include "penumbra/core/rng.h"
#include "penumbra/kernels/sampling.h"
#include "penumbra/raytrace/lights.h"
#include "penumbra/render/illuminance.h"
#include "penumbra/scene/luminaire.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>

namespace penumbra {

namespace {

struct ViewFrame {
  glm::dvec3 ahead, up, across;
  // R, T, H of the offset d from the eye.
  void place(const glm::dvec3& d, double& r, double& t, double& h) const {
    r = glm::dot(d, ahead);
    t = glm::dot(d, across);
    h = glm::dot(d, up);
  }
};

ViewFrame viewFrame(const glm::dvec3& view) {
  ViewFrame f;
  f.ahead = glm::normalize(view);
  const glm::dvec3 world_up(0.0, 1.0, 0.0);
  f.up = glm::normalize(world_up - glm::dot(world_up, f.ahead) * f.ahead);
  f.across = glm::cross(f.ahead, f.up);
  return f;
}

bool visible(const RayEngine& engine, const glm::dvec3& eye, const glm::dvec3& to) {
  return !engine.occluded(Ray{glm::vec3(eye), 1e-4f, glm::vec3(to - eye), 1.0f - 1e-4f});
}

// The projected luminous area of a luminaire towards the unit direction `out` (from it to the
// eye).
double luminaireArea(const LuminaireLight& l, const glm::dvec3& out) {
  return projectedLuminousArea(l.distribution->opening, glm::dot(out, glm::dvec3(l.c0)),
                               glm::dot(out, glm::dvec3(l.c90())),
                               glm::dot(out, glm::dvec3(l.nadir)));
}

std::string lightName(const Light& light, size_t index) {
  if (const auto* l = std::get_if<LuminaireLight>(&light)) {
    return fmt::format("light {} ({})", index + 1,
                       std::filesystem::path(l->distribution->source).filename().string());
  }
  return fmt::format("light {}", index + 1);
}

// The scene's delta lights as glare sources: intensity towards the eye (the normal irradiance
// at the eye times the squared distance) over the projected luminous area.
void lightSources(const Scene& scene, const RayEngine& engine, const glm::dvec3& eye,
                  const ViewFrame& frame, std::vector<GlareSource>& out) {
  for (size_t i = 0; i < scene.lights.size(); ++i) {
    const Light& light = scene.lights[i];
    if (std::holds_alternative<DirectionalLight>(light)) continue;
    const LightSample where = sampleLight(light, eye, frame.up, frame.up);
    if (!(where.distance > 0.0) || where.distance > 1e30) continue;
    const LightSample s = sampleLight(light, eye, where.direction, where.direction);
    const double candela = luxOf(s.irradiance) * s.distance * s.distance;
    const glm::dvec3 d = s.direction * s.distance;
    double r = 0.0, t = 0.0, h = 0.0;
    frame.place(d, r, t, h);
    double area = 0.0;
    if (const auto* l = std::get_if<LuminaireLight>(&light)) area = luminaireArea(*l, -s.direction);
    const GlareTerm term = glareTermOfIntensity(r, t, h, candela, area);
    if (!term.counted || !(term.term > 0.0) || !visible(engine, eye, eye + d)) continue;
    out.push_back({lightName(light, i), term});
  }
}

// Emitting surfaces: per triangle kSide^2 stratified points, each the solid angle
// area cos(theta) / (n r^2) with its own position index and shadow ray; summed per material.
void surfaceSources(const Scene& scene, const RayEngine& engine, const FlatTriangles& flat,
                    const glm::dvec3& eye, const ViewFrame& frame, uint64_t seed,
                    std::vector<GlareSource>& out) {
  constexpr uint32_t kSide = 8;
  struct Sum {
    double luminance = 0.0, solid_angle = 0.0, term = 0.0;
  };
  std::map<uint32_t, Sum> per_material;
  Rng rng(seed, 0x67a4e);
  for (size_t tri = 0; tri < flat.triangles.size(); ++tri) {
    const Material& m = scene.materials[flat.material_ids[tri]];
    if (!m.isEmissive() || m.emission_texture) continue;
    const glm::uvec3 v = flat.triangles[tri];
    const glm::dvec3 a(flat.positions[v.x]), b(flat.positions[v.y]), c(flat.positions[v.z]);
    const glm::dvec3 cr = glm::cross(b - a, c - a);
    const double len = glm::length(cr);
    if (!(len > 0.0) || !(glm::dot(cr, eye - a) > 0.0)) continue;  // degenerate, or its back
    const glm::dvec3 normal = cr / len;
    const double luminance = luxOf(glm::dvec3(m.emission));
    const double cell_area = 0.5 * len / double(kSide * kSide);
    Sum& sum = per_material[flat.material_ids[tri]];
    sum.luminance = luminance;
    for (uint32_t i = 0; i < kSide * kSide; ++i) {
      const glm::vec2 u = jitteredCell(i, kSide, rng.uniform(), rng.uniform());
      const glm::dvec3 q = pointOnTriangle(a, b, c, u.x, u.y);
      const glm::dvec3 d = q - eye;
      const double d2 = glm::dot(d, d);
      const double omega = cell_area * glm::dot(normal, -d) / (std::sqrt(d2) * d2);
      double r = 0.0, t = 0.0, h = 0.0;
      frame.place(d, r, t, h);
      const GlareTerm term = glareTermOfLuminance(r, t, h, luminance, omega);
      if (!term.counted || !visible(engine, eye, q)) continue;
      sum.solid_angle += omega;
      sum.term += term.term;
    }
  }
  for (const auto& [material, sum] : per_material) {
    if (!(sum.term > 0.0)) continue;
    GlareSource s{fmt::format("emitter '{}'", scene.materials[material].name), {}};
    s.term.luminance = sum.luminance;
    s.term.solid_angle = sum.solid_angle;
    s.term.term = sum.term;
    s.term.position_index = sum.luminance * std::sqrt(sum.solid_angle / sum.term);
    s.term.counted = true;
    out.push_back(s);
  }
}

}  // namespace

GlareResult glareAt(const Scene& scene, const RayEngine& engine, const FlatTriangles& flat,
                    const glm::dvec3& eye, const glm::dvec3& view, double background_luminance,
                    uint64_t seed) {
  const ViewFrame frame = viewFrame(view);
  GlareResult g;
  g.background_luminance = background_luminance;
  lightSources(scene, engine, eye, frame, g.sources);
  surfaceSources(scene, engine, flat, eye, frame, seed, g.sources);
  std::sort(g.sources.begin(), g.sources.end(),
            [](const GlareSource& a, const GlareSource& b) { return a.term.term > b.term.term; });
  for (const GlareSource& s : g.sources) g.sum += s.term.term;
  g.ugr = unifiedGlareRating(background_luminance, g.sum);
  return g;
}

}  // namespace penumbra
