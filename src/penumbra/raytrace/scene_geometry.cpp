#include "penumbra/raytrace/scene_geometry.h"

#include "penumbra/core/color.h"
#include "penumbra/kernels/sampling.h"
#include "penumbra/raytrace/cutout_filter.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>

namespace penumbra {

SceneGeometry SceneGeometry::build(const Scene& scene) {
  SceneGeometry g;
  g.materials = scene.materials;
  FlatTriangles flat = flattenScene(scene);
  g.positions = std::move(flat.positions);
  g.triangles = std::move(flat.triangles);
  g.material_ids = std::move(flat.material_ids);
  const size_t nt = g.triangles.size();
  g.normals.resize(nt);
  g.areas.resize(nt);
  g.surface_offsets.resize(nt);
  for (size_t i = 0; i < nt; ++i) {
    const glm::uvec3 t = g.triangles[i];
    const glm::vec3 c =
        glm::cross(g.positions[t.y] - g.positions[t.x], g.positions[t.z] - g.positions[t.x]);
    const float len = glm::length(c);
    g.areas[i] = 0.5f * len;
    g.normals[i] = len > 0.0f ? c / len : glm::vec3(0.0f);
    const glm::vec3 &p0 = g.positions[t.x], &p1 = g.positions[t.y], &p2 = g.positions[t.z];
    constexpr float kGamma7 = 7.0f * 0x1p-24f / (1.0f - 7.0f * 0x1p-24f);
    const glm::vec3 m = glm::max(glm::max(glm::abs(p0), glm::abs(p1)), glm::abs(p2));
    const float magnitude = std::max(std::max(m.x, m.y), std::max(m.z, 1e-6f));
    g.surface_offsets[i] =
        glm::dot(glm::abs(g.normals[i]), 2.0f * kGamma7 * m) + 64.0f * 0x1p-24f * magnitude;
  }
  g.engine = RayEngine::build(g.positions, g.triangles);
  g.textures = std::make_shared<const SurfaceTextures>(scene);
  g.engine.setHitFilter(cutoutFilter(g.textures));

  g.emitter_pick_pdf.assign(nt, 0.0f);
  double total = 0.0;
  std::vector<double> power;
  for (size_t i = 0; i < nt; ++i) {
    const Material& m = g.materials[g.material_ids[i]];
    // An unlit surface's emission is what the camera sees of it, not light (Material::unlit).
    if (m.isEmissive() && !m.unlit && g.areas[i] > 0.0f) {
      // A textured or cut-out emitter by its mean emission over the triangle.
      const bool varies = g.textures->varies(uint32_t(i)) || g.textures->isCutout(uint32_t(i));
      const glm::vec3 le =
          varies ? glm::vec3(g.textures->triangleMean(uint32_t(i)).emission) : m.emission;
      const double p = double(luminance(le)) * g.areas[i];
      // A coloured emitter with zero luminance still needs to be sampled; a textured one that is
      // black all over does not.
      const double w = p > 0.0 ? p : double(std::max({le.x, le.y, le.z})) * g.areas[i];
      if (!(w > 0.0)) continue;
      g.emitters.push_back(uint32_t(i));
      power.push_back(w);
      total += w;
    }
  }
  g.total_emitted_power = float(total * kPi);
  // The CDF in 32-bit fixed point; each emitter's pick probability is the width of its interval,
  // exactly (an emitter too faint for one step of 2^-32 is never picked, and its pdf says so).
  double acc = 0.0;
  uint64_t lo = 0;
  for (size_t k = 0; k < g.emitters.size(); ++k) {
    acc += power[k];
    const uint64_t hi =
        k + 1 == g.emitters.size()
            ? kEmitterCdfOne
            : std::min(kEmitterCdfOne, uint64_t(std::llround(acc / total * 0x1p32)));
    g.emitter_cdf.push_back(std::max(hi, lo));
    const uint64_t width = g.emitter_cdf.back() - lo;
    g.emitter_pick_pdf[g.emitters[k]] = float(double(width) * 0x1p-32);
    g.emitter_width_inverse.push_back(width > 0 ? float(1.0 / double(width)) : 0.0f);
    lo = g.emitter_cdf.back();
  }
  return g;
}

}  // namespace penumbra
