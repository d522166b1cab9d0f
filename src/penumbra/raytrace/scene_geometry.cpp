#include "penumbra/raytrace/scene_geometry.h"

#include "penumbra/kernels/sampling.h"
#include "penumbra/render/tonemap.h"

#include <glm/geometric.hpp>

#include <algorithm>

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
  for (size_t i = 0; i < nt; ++i) {
    const glm::uvec3 t = g.triangles[i];
    const glm::vec3 c =
        glm::cross(g.positions[t.y] - g.positions[t.x], g.positions[t.z] - g.positions[t.x]);
    const float len = glm::length(c);
    g.areas[i] = 0.5f * len;
    g.normals[i] = len > 0.0f ? c / len : glm::vec3(0.0f);
  }
  g.engine = RayEngine::build(g.positions, g.triangles);

  g.emitter_pick_pdf.assign(nt, 0.0f);
  double total = 0.0;
  std::vector<double> power;
  for (size_t i = 0; i < nt; ++i) {
    const Material& m = g.materials[g.material_ids[i]];
    const double p = double(luminance(m.emission)) * g.areas[i];
    if (m.isEmissive() && g.areas[i] > 0.0f) {
      // A coloured emitter with zero luminance still needs to be sampled.
      const double w =
          p > 0.0 ? p : double(std::max({m.emission.x, m.emission.y, m.emission.z})) * g.areas[i];
      g.emitters.push_back(uint32_t(i));
      power.push_back(w);
      total += w;
    }
  }
  g.total_emitted_power = float(total * kPi);
  double acc = 0.0;
  for (size_t k = 0; k < g.emitters.size(); ++k) {
    acc += power[k];
    g.emitter_cdf.push_back(float(acc / total));
    g.emitter_pick_pdf[g.emitters[k]] = float(power[k] / total);
  }
  if (!g.emitter_cdf.empty()) g.emitter_cdf.back() = 1.0f;
  return g;
}

uint32_t SceneGeometry::pickEmitter(float u) const {
  const auto it = std::upper_bound(emitter_cdf.begin(), emitter_cdf.end(), u);
  const size_t k = std::min(size_t(it - emitter_cdf.begin()), emitter_cdf.size() - 1);
  return uint32_t(k);
}

}  // namespace penumbra
