#include "penumbra/render/lightmap_mesh.h"

#include "penumbra/core/check.h"
#include "penumbra/render/lightmap_view.h"

#include <glm/geometric.hpp>

#include <algorithm>

namespace penumbra {

BakedMesh buildLightmapMesh(const Scene& scene, const ChartAtlas& atlas, const Image& lightmap) {
  const FlatTriangles flat = flattenScene(scene);
  const size_t n_tri = flat.triangles.size();
  PENUMBRA_CHECK(lightmap.width == atlas.width && lightmap.height == atlas.height);
  BakedMesh out;
  const std::vector<glm::vec2> scene_uv = flattenSceneUvs(scene, out.has_scene_uvs);

  uint32_t n_materials = 0;
  for (uint32_t m : flat.material_ids) n_materials = std::max(n_materials, m + 1);
  // Faces by material: a two-sided surface's back face is a triangle of its own, wound the
  // other way, with its own lightmap UVs.
  std::vector<std::vector<uint32_t>> by_material(n_materials);
  for (uint32_t f = 0; f < atlas.faces.size(); ++f) {
    if (atlas.charts.face_chart[f] < 0) continue;
    by_material[flat.material_ids[atlas.faces[f].triangle]].push_back(f);
  }

  out.positions.reserve(3 * n_tri);
  out.triangles.reserve(n_tri);
  for (uint32_t material = 0; material < n_materials; ++material) {
    BakedMesh::Group group;
    group.material = material;
    group.first_vertex = uint32_t(out.positions.size());
    group.first_triangle = uint32_t(out.triangles.size());
    for (uint32_t f : by_material[material]) {
      const uint32_t t = atlas.faces[f].triangle;
      const bool back = atlas.faces[f].back;
      const glm::uvec3 tri = flat.triangles[t];
      const glm::vec3 p[3] = {flat.positions[tri.x], flat.positions[tri.y], flat.positions[tri.z]};
      const glm::vec3 c = glm::cross(p[1] - p[0], p[2] - p[0]);
      const float len = glm::length(c);
      if (!(len > 0.0f)) continue;
      const uint32_t v = uint32_t(out.positions.size());
      const int order[2][3] = {{0, 1, 2}, {0, 2, 1}};
      for (int j = 0; j < 3; ++j) {
        const int k = order[back ? 1 : 0][j];
        const glm::vec2 uv = atlas.uvs[3 * size_t(f) + size_t(k)];
        out.positions.push_back(p[k]);
        out.normals.push_back((back ? -c : c) / len);
        out.values.push_back(sampleBilinear(lightmap, uv));
        out.uv0.push_back(scene_uv[3 * size_t(t) + size_t(k)]);
        out.uv1.push_back(uv);
      }
      out.triangles.emplace_back(v, v + 1, v + 2);
      out.element.push_back(t);
    }
    group.vertex_count = uint32_t(out.positions.size()) - group.first_vertex;
    group.triangle_count = uint32_t(out.triangles.size()) - group.first_triangle;
    if (group.triangle_count > 0) out.groups.push_back(group);
  }
  return out;
}

}  // namespace penumbra
