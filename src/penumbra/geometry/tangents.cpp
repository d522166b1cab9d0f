#include "penumbra/geometry/tangents.h"

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <cmath>
#include <map>
#include <tuple>

namespace penumbra {

namespace {

// A unit vector perpendicular to unit n.
glm::dvec3 anyPerpendicular(const glm::dvec3& n) {
  const glm::dvec3 a = std::abs(n.x) < 0.6 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  return glm::normalize(glm::cross(a, n));
}

// The angle at corner a of triangle (a, b, c).
double cornerAngle(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
  const glm::dvec3 u = b - a, v = c - a;
  const double lu = glm::length(u), lv = glm::length(v);
  if (!(lu > 0.0 && lv > 0.0)) return 0.0;
  return std::acos(std::clamp(glm::dot(u, v) / (lu * lv), -1.0, 1.0));
}

}  // namespace

std::vector<glm::vec4> cornerTangents(const Scene& scene,
                                      std::span<const glm::vec3> corner_normals) {
  std::vector<glm::vec4> out;
  out.reserve(corner_normals.size());
  size_t corner = 0;
  for (const Mesh& mesh : scene.meshes) {
    const size_t first = corner;
    const size_t nt = mesh.triangles.size();
    // Per triangle: the UV-derivative tangent (unnormalised) and handedness.
    std::vector<glm::dvec3> tri_tangent(nt, glm::dvec3(0.0));
    std::vector<float> tri_sign(nt, 1.0f);
    std::vector<uint8_t> tri_ok(nt, 0);
    // Corners sharing position, normal, UV and handedness pool their tangents.
    using Key = std::tuple<uint32_t, float, float, float, float, float, float>;
    std::map<Key, glm::dvec3> pooled;
    std::vector<Key> keys(3 * nt);
    for (size_t t = 0; t < nt; ++t) {
      const glm::uvec3 tri = mesh.triangles[t];
      const glm::dvec3 p[3] = {glm::dvec3(mesh.positions[tri.x]), glm::dvec3(mesh.positions[tri.y]),
                               glm::dvec3(mesh.positions[tri.z])};
      if (!mesh.uvs.empty()) {
        // v up the image in either convention (scene/mesh.h).
        auto up = [&](uint32_t i) {
          const glm::vec2 w = mesh.uvs[i];
          return glm::dvec2(w.x, mesh.uv_origin_top ? 1.0 - double(w.y) : double(w.y));
        };
        const glm::dvec2 w0 = up(tri.x), w1 = up(tri.y), w2 = up(tri.z);
        const glm::dvec3 e1 = p[1] - p[0], e2 = p[2] - p[0];
        const glm::dvec2 d1 = w1 - w0, d2 = w2 - w0;
        const double r = d1.x * d2.y - d2.x * d1.y;
        if (std::abs(r) > 1e-20) {
          const glm::dvec3 tan = (e1 * d2.y - e2 * d1.y) / r;
          const glm::dvec3 bit = (e2 * d1.x - e1 * d2.x) / r;
          const glm::dvec3 face = glm::cross(e1, e2);
          if (glm::length(tan) > 0.0) {
            tri_tangent[t] = glm::normalize(tan);
            tri_sign[t] = glm::dot(glm::cross(face, tan), bit) < 0.0 ? -1.0f : 1.0f;
            tri_ok[t] = 1;
          }
        }
      }
      for (int k = 0; k < 3; ++k) {
        const uint32_t v = tri[k];
        const glm::vec3 n = corner_normals[first + 3 * t + size_t(k)];
        const glm::vec2 uv = mesh.uvs.empty() ? glm::vec2(0.0f) : mesh.uvs[v];
        keys[3 * t + size_t(k)] = Key{v, n.x, n.y, n.z, uv.x, uv.y, tri_sign[t]};
        if (tri_ok[t]) {
          pooled[keys[3 * t + size_t(k)]] +=
              tri_tangent[t] * cornerAngle(p[k], p[(k + 1) % 3], p[(k + 2) % 3]);
        }
      }
    }
    for (size_t t = 0; t < nt; ++t) {
      for (int k = 0; k < 3; ++k) {
        const glm::dvec3 n(corner_normals[first + 3 * t + size_t(k)]);
        glm::dvec3 tan(0.0);
        if (tri_ok[t]) tan = pooled[keys[3 * t + size_t(k)]];
        tan -= n * glm::dot(n, tan);  // Gram-Schmidt against the corner's normal
        const double len = glm::length(tan);
        const glm::dvec3 unit =
            len > 1e-12 ? tan / len
                        : (glm::length(n) > 0.0 ? anyPerpendicular(n) : glm::dvec3(1, 0, 0));
        out.emplace_back(glm::vec3(unit), tri_sign[t]);
      }
    }
    corner += 3 * nt;
  }
  return out;
}

glm::dvec3 perturbedNormal(const glm::dvec3& n, const glm::vec4& tangent, const glm::vec3& rgb,
                           float scale) {
  const glm::dvec3 t(tangent.x, tangent.y, tangent.z);
  const glm::dvec3 b = double(tangent.w) * glm::cross(n, t);
  const glm::dvec3 local((2.0 * rgb.x - 1.0) * scale, (2.0 * rgb.y - 1.0) * scale,
                         2.0 * rgb.z - 1.0);
  const glm::dvec3 world = local.x * t + local.y * b + local.z * n;
  const double len = glm::length(world);
  return len > 0.0 ? world / len : n;
}

glm::vec3 sampleNormalMap(const Image& map, glm::vec2 uv, bool uv_origin_top) {
  // Texel (x, y) centred at ((x + 0.5) / width, (y + 0.5) / height) from the image's top-left;
  // repeating in both directions.
  const float v_top = uv_origin_top ? uv.y : 1.0f - uv.y;
  const float u = uv.x - std::floor(uv.x), v = v_top - std::floor(v_top);  // one period
  const float fx = u * float(map.width) - 0.5f, fy = v * float(map.height) - 0.5f;
  const float x0f = std::floor(fx), y0f = std::floor(fy);
  const float tx = fx - x0f, ty = fy - y0f;
  auto wrap = [](int i, int n) { return ((i % n) + n) % n; };
  auto at = [&](int x, int y) { return map.at(wrap(x, map.width), wrap(y, map.height)); };
  const int x0 = int(x0f), y0 = int(y0f);
  return (1.0f - ty) * ((1.0f - tx) * at(x0, y0) + tx * at(x0 + 1, y0)) +
         ty * ((1.0f - tx) * at(x0, y0 + 1) + tx * at(x0 + 1, y0 + 1));
}

}  // namespace penumbra
