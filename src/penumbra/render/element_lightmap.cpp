#include "penumbra/render/element_lightmap.h"

#include "penumbra/core/check.h"
#include "penumbra/core/parallel.h"

#include <glm/common.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

namespace penumbra {

ElementLocator::ElementLocator(const Elements& elements) {
  const size_t n_tri = elements.scene.triangles.size();
  first_.assign(n_tri, 0);
  rows_.assign(n_tri, 0);
  std::vector<uint32_t> count(n_tri, 0);
  for (size_t e = 0; e < elements.size(); ++e) {
    const uint32_t t = elements.source[e];
    PENUMBRA_CHECK_MSG(t < n_tri, "element {} refines triangle {} of {}", e, t, n_tri);
    if (count[t] == 0) first_[t] = uint32_t(e);
    // A scene triangle's elements are stored together.
    PENUMBRA_CHECK_MSG(first_[t] + count[t] == e, "element {} of triangle {}", e, t);
    ++count[t];
  }
  for (size_t t = 0; t < n_tri; ++t) {
    if (count[t] == 0) continue;
    const uint32_t m = uint32_t(std::lround(std::sqrt(double(count[t]))));
    PENUMBRA_CHECK_MSG(m * m == count[t] && std::has_single_bit(m),
                       "triangle {} has {} elements, not a power of 4", t, count[t]);
    rows_[t] = m;
  }
}

uint32_t ElementLocator::element(uint32_t t, uint32_t i, uint32_t j, bool upper) const {
  const uint32_t m = rows_[t];
  // Row j starts after sum_{j' < j} (2 (m - j') - 1) = j (2m - j) elements.
  return first_[t] + j * (2 * m - j) + 2 * i + (upper ? 1 : 0);
}

ElementLocator::Location ElementLocator::locate(uint32_t t, glm::vec2 barycentric) const {
  Location loc;
  const uint32_t m = rows_[t];
  if (m == 0) return loc;
  const float fm = float(m);
  // Grid coordinates (s, r) = m (w1, w2) of the point and of its clamp to the triangle.
  const glm::vec2 g = barycentric * fm;
  const glm::vec2 gc = clampBarycentric(barycentric) * fm;
  const int max_index = int(m) - 1;
  const int i = std::clamp(int(std::floor(gc.x)), 0, max_index);
  const int j = std::clamp(int(std::floor(gc.y)), 0, max_index - i);
  const bool upper = i + j + 1 < int(m) && (gc.x - float(i)) + (gc.y - float(j)) > 1.0f;
  const float ls = g.x - float(i), lr = g.y - float(j);
  loc.element = element(t, uint32_t(i), uint32_t(j), upper);
  // Lower element corners (i, j), (i+1, j), (i, j+1); upper (i+1, j), (i+1, j+1), (i, j+1).
  loc.weights =
      upper ? glm::vec3(1.0f - lr, ls + lr - 1.0f, 1.0f - ls) : glm::vec3(1.0f - ls - lr, ls, lr);
  return loc;
}

glm::vec3 interpolateCornerValues(const ElementLocator& locator,
                                  std::span<const glm::vec3> corner_values, uint32_t t,
                                  glm::vec2 barycentric) {
  const ElementLocator::Location loc = locator.locate(t, barycentric);
  if (loc.element < 0) return glm::vec3(0.0f);
  const size_t k = 3 * size_t(loc.element);
  const glm::vec3 v = corner_values[k] * loc.weights.x + corner_values[k + 1] * loc.weights.y +
                      corner_values[k + 2] * loc.weights.z;
  return glm::max(v, glm::vec3(0.0f));
}

Image rasterizeElementLightmap(const LightmapAtlas& atlas, const Elements& elements,
                               std::span<const glm::vec3> corner_values) {
  PENUMBRA_CHECK_MSG(atlas.charts.size() == elements.scene.triangles.size(),
                     "atlas of {} triangles for a scene of {}", atlas.charts.size(),
                     elements.scene.triangles.size());
  PENUMBRA_CHECK(corner_values.size() == 3 * elements.size());
  const ElementLocator locator(elements);
  Image image(atlas.width, atlas.height);
  parallelRange(size_t(atlas.height), 8, [&](size_t y0, size_t y1) {
    for (size_t y = y0; y < y1; ++y) {
      for (int x = 0; x < atlas.width; ++x) {
        const size_t at = atlas.texelIndex(x, int(y));
        const int32_t t = atlas.texel_triangle[at];
        if (t < 0) continue;
        image.pixels[at] = interpolateCornerValues(locator, corner_values, uint32_t(t),
                                                   atlas.texel_barycentric[at]);
      }
    }
  });
  return image;
}

BakedMesh buildBakedMesh(const Scene& scene, const Elements& elements, const LightmapAtlas& atlas,
                         std::span<const glm::vec3> corner_values) {
  const FlatTriangles& flat = elements.scene;
  const size_t n_tri = flat.triangles.size();
  PENUMBRA_CHECK(atlas.charts.size() == n_tri);
  PENUMBRA_CHECK(corner_values.size() == 3 * elements.size());
  const ElementLocator locator(elements);

  BakedMesh out;
  const std::vector<glm::vec2> scene_uv = flattenSceneUvs(scene, out.has_scene_uvs);
  PENUMBRA_CHECK_MSG(scene_uv.size() == 3 * n_tri, "scene has {} triangles, its elements {}",
                     scene_uv.size() / 3, n_tri);

  uint32_t n_materials = 0;
  for (uint32_t m : flat.material_ids) n_materials = std::max(n_materials, m + 1);
  std::vector<std::vector<uint32_t>> by_material(n_materials);
  for (uint32_t t = 0; t < n_tri; ++t) {
    if (locator.rows(t) > 0) by_material[flat.material_ids[t]].push_back(t);
  }

  out.positions.reserve(elements.positions.size() * 2);
  out.triangles.reserve(elements.size());
  out.element.reserve(elements.size());
  // Per grid vertex of the current scene triangle: the output vertices made for it (usually one;
  // more where elements sharing it carry different values).
  std::vector<std::vector<uint32_t>> made;
  for (uint32_t material = 0; material < n_materials; ++material) {
    if (by_material[material].empty()) continue;
    BakedMesh::Group group;
    group.material = material;
    group.first_vertex = uint32_t(out.positions.size());
    group.first_triangle = uint32_t(out.triangles.size());
    for (uint32_t t : by_material[material]) {
      const uint32_t m = locator.rows(t);
      made.assign(size_t(m + 1) * size_t(m + 1), {});
      auto vertex = [&](uint32_t e, int k, uint32_t i, uint32_t j) -> uint32_t {
        const glm::vec3 value = corner_values[3 * size_t(e) + size_t(k)];
        std::vector<uint32_t>& list = made[size_t(j) * (m + 1) + i];
        for (uint32_t v : list) {
          if (std::memcmp(&out.values[v], &value, sizeof(value)) == 0) return v;
        }
        const uint32_t v = uint32_t(out.positions.size());
        const glm::vec2 b(float(i) / float(m), float(j) / float(m));
        out.positions.push_back(elements.positions[elements.triangles[e][k]]);
        out.normals.push_back(elements.normal[e]);
        out.values.push_back(value);
        out.uv0.push_back(scene_uv[3 * t] * (1.0f - b.x - b.y) + scene_uv[3 * t + 1] * b.x +
                          scene_uv[3 * t + 2] * b.y);
        out.uv1.push_back(atlas.uv(t, b));
        list.push_back(v);
        return v;
      };
      for (uint32_t j = 0; j < m; ++j) {
        for (uint32_t i = 0; i + j < m; ++i) {
          const uint32_t lower = locator.element(t, i, j, false);
          out.triangles.emplace_back(vertex(lower, 0, i, j), vertex(lower, 1, i + 1, j),
                                     vertex(lower, 2, i, j + 1));
          out.element.push_back(lower);
          if (i + j + 1 < m) {
            const uint32_t upper = locator.element(t, i, j, true);
            out.triangles.emplace_back(vertex(upper, 0, i + 1, j), vertex(upper, 1, i + 1, j + 1),
                                       vertex(upper, 2, i, j + 1));
            out.element.push_back(upper);
          }
        }
      }
    }
    group.vertex_count = uint32_t(out.positions.size()) - group.first_vertex;
    group.triangle_count = uint32_t(out.triangles.size()) - group.first_triangle;
    out.groups.push_back(group);
  }
  return out;
}

}  // namespace penumbra
