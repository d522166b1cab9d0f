#include "penumbra/subsurface/sss.h"

#include "penumbra/core/memory.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/core/timer.h"
#include "penumbra/kernels/dipole.h"
#include "penumbra/kernels/form_factor.h"
#include "penumbra/kernels/sampling.h"
#include "penumbra/raytrace/lights.h"
#include "penumbra/subsurface/sss_cache.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include <atomic>
#include <limits>
#include <numbers>
#include <optional>

namespace penumbra {

Expected<SssSolver> SssSolver::buildSurface(const Scene& scene, const SssOptions& options) {
  SssSolver s;
  s.scene_ = scene;
  s.options_ = options;
  bool any = false;
  for (Material& m : s.scene_.materials) {
    if (!m.subsurface) continue;
    any = true;
    m.two_sided = false;  // the medium is inside: elements on the outside only
  }
  if (!any) {
    return inputError(scene.source, "",
                      "no material has a subsurface block: nothing is translucent (see "
                      "docs/scene-format.md, subsurface)");
  }
  Expected<ChartAtlasOptions> atlas = lightmapAtlasOptions(s.scene_, options.resolution);
  if (!atlas) return atlas.error();
  // The links dominate: a node index, an RGB factor and an offset per link.
  const uint64_t texels = expectedLightmapElements(s.scene_, options.resolution);
  const uint64_t per = options.links.level >= 0 ? 256 : uint64_t(std::max(1, options.links.links));
  PENUMBRA_TRY(
      checkMemory(texels * (per * 28 + 400),
                  fmt::format("subsurface links for about {} texels, {} each", texels, per)));
  Expected<RadiositySurface> surface = RadiositySurface::build(s.scene_, *atlas, true);
  if (!surface) return surface.error();
  s.surface_ = std::move(*surface);
  return s;
}

Status SssSolver::check(const Scene& scene, const SssOptions& options) {
  const Expected<SssSolver> s = buildSurface(scene, options);
  return s.ok() ? Status{} : Status(s.error());
}

Expected<SssSolver> SssSolver::build(const Scene& scene, const SssOptions& options,
                                     const std::function<void(size_t, size_t)>& progress) {
  const Timer timer;
  Expected<SssSolver> surfaced = buildSurface(scene, options);
  if (!surfaced) return surfaced;
  SssSolver& s = *surfaced;
  s.tree_ = buildSssTree(s.surface_, s.scene_.materials);
  s.media_ = objectMedia(s.tree_, s.scene_.materials);
  const size_t elements = s.surface_.elementCount();
  s.eta_.assign(elements, 0.0f);
  for (size_t e = 0; e < elements; ++e) {
    const int32_t o = s.tree_.object[e];
    if (o >= 0)
      s.eta_[e] = float(s.scene_.materials[s.tree_.object_material[size_t(o)]].subsurface->eta);
  }
  s.static_irradiance_ = s.computeEmitterIrradiance();
  s.addEnvironmentIrradiance(s.static_irradiance_);
  const uint64_t fingerprint = sssLinksFingerprint(s.tree_, s.media_, options.links);
  if (std::optional<SssLinks> cached =
          readCachedSssLinks(options.cache_directory, fingerprint, s.tree_)) {
    s.links_ = std::move(*cached);
    s.links_from_cache_ = true;
  } else {
    s.links_ = buildSssLinks(s.tree_, s.media_, options.links, [&](size_t done) {
      if (progress) progress(done, elements);
    });
    if (!options.cache_directory.empty()) {
      if (Status w = writeCachedSssLinks(options.cache_directory, fingerprint, s.tree_, s.links_);
          !w.ok()) {
        s.cache_problem_ = w.error().describe();
      }
    }
  }
  s.build_seconds_ = timer.seconds();
  return surfaced;
}

std::vector<glm::vec3> SssSolver::transmittedIrradiance(std::span<const Light> lights,
                                                        uint64_t* rays) const {
  const size_t n = surface_.elementCount();
  std::vector<glm::vec3> out(n, glm::vec3(0.0f));
  std::atomic<uint64_t> traced{0};
  parallelRange(n, 1024, [&](size_t begin, size_t end) {
    uint64_t count = 0;
    for (size_t e = begin; e < end; ++e) {
      if (eta_[e] == 0.0f) continue;
      const glm::dvec3 p = surface_.atlas.element_position[e];
      const glm::dvec3 ng = surface_.atlas.element_normal[e];
      const glm::dvec3 ns = surface_.shading_normal[e];
      glm::dvec3 sum(0.0);
      for (const Light& light : lights) {
        const LightSample ls = sampleLight(light, p, ng, ns);
        if (ls.irradiance == glm::dvec3(0.0)) continue;
        if (options_.shadows) {
          const glm::dvec3 from = p + ng * surface_.lift;
          const bool far = ls.distance > 1e30;
          Ray ray{glm::vec3(from), 1e-4f,
                  far ? glm::vec3(ls.direction) : glm::vec3(ls.direction * ls.distance),
                  far ? std::numeric_limits<float>::max() : 1.0f - 1e-4f};
          ++count;
          if (surface_.engine.occluded(ray)) continue;
        }
        // Eq. 8: the light that crosses the boundary.
        sum += ls.irradiance * fresnelTransmittance(eta_[e], glm::dot(ls.direction, ns));
      }
      out[e] = glm::vec3(sum) + static_irradiance_[e];
    }
    traced += count;
  });
  if (rays) *rays += traced.load();
  return out;
}

std::vector<glm::vec3> SssSolver::computeEmitterIrradiance() const {
  const size_t n = surface_.elementCount();
  std::vector<glm::vec3> out(n, glm::vec3(0.0f));
  const FlatTriangles& flat = surface_.flat;
  std::vector<uint32_t> emitters;
  for (size_t t = 0; t < flat.triangles.size(); ++t) {
    const Material& m = scene_.materials[flat.material_ids[t]];
    if (m.isEmissive() && !m.subsurface) emitters.push_back(uint32_t(t));
  }
  if (emitters.empty()) return out;
  // Four fixed points on each emitter for its visibility (barycentrics of vertices 1 and 2).
  const glm::dvec2 points[4] = {
      {1.0 / 6, 1.0 / 6}, {2.0 / 3, 1.0 / 6}, {1.0 / 6, 2.0 / 3}, {1.0 / 3, 1.0 / 3}};
  parallelRange(n, 256, [&](size_t begin, size_t end) {
    for (size_t e = begin; e < end; ++e) {
      if (eta_[e] == 0.0f) continue;
      const glm::dvec3 x = surface_.atlas.element_position[e];
      const glm::dvec3 ng = surface_.atlas.element_normal[e];
      const glm::dvec3 ns = surface_.shading_normal[e];
      const glm::dvec3 from = x + ng * surface_.lift;
      glm::dvec3 sum(0.0);
      for (uint32_t t : emitters) {
        const glm::uvec3 tri = flat.triangles[t];
        const glm::dvec3 a(flat.positions[tri.x]), b(flat.positions[tri.y]),
            c(flat.positions[tri.z]);
        const glm::dvec3 centroid = (a + b + c) / 3.0;
        // Front faces emit: the receiver must be in front of the emitter, and the emitter in
        // front of the receiver.
        if (glm::dot(x - centroid, glm::cross(b - a, c - a)) <= 0.0) continue;
        const glm::dvec3 to = centroid - x;
        const double cos_r = glm::dot(glm::normalize(to), ns);
        if (cos_r <= 0.0 && glm::dot(to, ng) <= 0.0) continue;
        const double f = pointToTriangleFormFactor(x, ns, a, b, c);
        if (!(f > 0.0)) continue;
        int visible = 0;
        for (const glm::dvec2& w : points) {
          const glm::dvec3 q = (1.0 - w.x - w.y) * a + w.x * b + w.y * c;
          const Ray ray{glm::vec3(from), 1e-4f, glm::vec3(q - from), 1.0f - 1e-4f};
          visible += surface_.engine.occluded(ray) ? 0 : 1;
        }
        if (visible == 0) continue;
        const glm::dvec3 le(scene_.materials[flat.material_ids[t]].emission);
        sum += std::numbers::pi * le * f * (visible / 4.0) *
               fresnelTransmittance(eta_[e], std::max(0.0, cos_r));
      }
      out[e] = glm::vec3(sum);
    }
  });
  return out;
}

void SssSolver::addEnvironmentIrradiance(std::vector<glm::vec3>& out) const {
  const glm::dvec3 env(scene_.environment);
  if (env == glm::dvec3(0.0)) return;
  // E = int L_env V F_t(cos) cos dw = pi L_env E_p[V F_t] with p = cos / pi: 8 x 8 strata of
  // cosine-distributed directions about the shading normal, from a fixed stream per element.
  constexpr int kStrata = 8;
  parallelRange(out.size(), 256, [&](size_t begin, size_t end) {
    for (size_t e = begin; e < end; ++e) {
      if (eta_[e] == 0.0f) continue;
      const glm::vec3 x(surface_.atlas.element_position[e]);
      const glm::vec3 ng(surface_.atlas.element_normal[e]);
      const glm::vec3 ns(surface_.shading_normal[e]);
      const Frame frame = Frame::fromNormal(ns);
      const glm::vec3 from = x + ng * float(surface_.lift);
      Rng rng(0x5eed, e);
      double sum = 0.0;
      for (int k = 0; k < kStrata * kStrata; ++k) {
        const float u1 = (float(k % kStrata) + rng.uniform()) / kStrata;
        const float u2 = (float(k / kStrata) + rng.uniform()) / kStrata;
        const glm::vec3 d = frame.toWorld(sampleCosineHemisphere(u1, u2));
        if (glm::dot(d, ng) <= 0.0f) continue;  // below the face: the surface blocks it
        const Ray ray{from, 1e-4f, d, std::numeric_limits<float>::max()};
        if (surface_.engine.occluded(ray)) continue;
        sum += fresnelTransmittance(eta_[e], double(glm::dot(d, ns)));
      }
      out[e] += glm::vec3(std::numbers::pi * env * sum / double(kStrata * kStrata));
    }
  });
}

std::vector<glm::vec3> SssSolver::scatter(std::span<const glm::vec3> irradiance) const {
  std::vector<glm::vec3> b(surface_.elementCount());
  gatherScattered(links_, mipMapIrradiance(tree_, irradiance), b);
  return b;
}

Image SssSolver::scatteredRadianceAtlas(std::span<const glm::vec3> scattered) const {
  return surface_.radianceImage(scattered);
}

}  // namespace penumbra
