#include "penumbra/radiosity/texel_footprint.h"

#include "penumbra/core/parallel.h"
#include "penumbra/radiosity/radiosity_surface.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>

namespace penumbra {

namespace {

// Points spread over a footprint: stratified by area along u0, an R2 sequence (Roberts 2018)
// for the place in the triangle.
constexpr int kAnchorPoints = 8;
constexpr int kAnchorMargin = 2;

glm::vec3 anchorSample(int k) {
  const double a1 = 0.7548776662466927, a2 = 0.5698402909980532;
  return glm::vec3(float((k + 0.5) / kAnchorPoints), float(std::fmod(0.5 + k * a1, 1.0)),
                   float(std::fmod(0.5 + k * a2, 1.0)));
}

}  // namespace

glm::dvec3 TexelFootprint::sample(float u0, float u1, float u2, uint32_t* face_out) const {
  const double pick = double(u0) * cumulative.back();
  const size_t i = std::min(
      size_t(std::upper_bound(cumulative.begin(), cumulative.end(), pick) - cumulative.begin()),
      triangles.size() - 1);
  if (face_out) *face_out = face[i];
  const auto& t = triangles[i];
  const double s = std::sqrt(double(u1));
  return t[0] * (1.0 - s) + t[1] * (s * (1.0 - double(u2))) + t[2] * (s * double(u2));
}

TexelFootprint texelFootprint(const RadiositySurface& surface, size_t e) {
  const ChartAtlas& atlas = surface.atlas;
  TexelFootprint f;
  f.normal = atlas.element_normal[e];
  double sum = 0.0;
  const glm::ivec2 t = atlas.texelOf(e);
  atlas.forEachPiece(
      t, t, atlas.elementFaces(e), surface.flat.positions, surface.flat.triangles,
      [&](uint32_t face, const std::array<glm::dvec3, 8>& poly, int n, double) {
        for (int k = 1; k + 1 < n; ++k) {
          const std::array<glm::dvec3, 3> tri = {poly[0], poly[size_t(k)], poly[size_t(k + 1)]};
          const double area = 0.5 * glm::length(glm::cross(tri[1] - tri[0], tri[2] - tri[0]));
          if (!(area > 0.0)) continue;
          sum += area;
          f.triangles.push_back(tri);
          f.cumulative.push_back(sum);
          f.face.push_back(face);
        }
      });
  if (f.triangles.empty()) {  // a sliver: its point stands for it
    const glm::dvec3 p = atlas.element_position[e];
    f.triangles.push_back({p, p, p});
    f.cumulative.push_back(1.0);
    f.face.push_back(atlas.element_face[e]);
  }
  return f;
}

double footprintLift(const RadiositySurface& surface) {
  // As the path-traced bake's rays down onto the surface: far below any gap a model leaves
  // between a surface and what it holds (a ceiling light 1 mm under the ceiling).
  return 4.0 * surface.lift;
}

bool footprintPointsSeeEachOther(const RadiositySurface& surface, const glm::dvec3& p,
                                 const glm::dvec3& q, const glm::dvec3& normal, double lift) {
  const glm::dvec3 a = p + normal * lift, b = q + normal * lift;
  const glm::dvec3 d = b - a;
  const double length = glm::length(d);
  if (!(length > 0.0)) return true;
  const Ray ray{glm::vec3(a), 0.0f, glm::vec3(d / length), float(length)};
  return !surface.engine.occluded(ray);
}

size_t anchorElements(RadiositySurface& surface) {
  ChartAtlas& atlas = surface.atlas;
  const double lift = footprintLift(surface);
  std::atomic<size_t> moved{0};
  parallelRange(atlas.elementCount(), 256, [&](size_t begin, size_t end) {
    constexpr int kPoints = kAnchorPoints + 1;
    for (size_t e = begin; e < end; ++e) {
      const TexelFootprint f = texelFootprint(surface, e);
      glm::dvec3 point[kPoints];
      uint32_t face[kPoints];
      point[0] = atlas.element_position[e];
      face[0] = atlas.element_face[e];
      for (int k = 0; k < kAnchorPoints; ++k) {
        const glm::vec3 u = anchorSample(k);
        point[k + 1] = f.sample(u.x, u.y, u.z, &face[k + 1]);
      }
      // The element's point sees all of them: nothing crosses the footprint.
      bool sees[kPoints][kPoints] = {};
      int score[kPoints] = {};
      bool all = true;
      for (int j = 1; j < kPoints; ++j) {
        sees[0][j] = sees[j][0] =
            footprintPointsSeeEachOther(surface, point[0], point[j], f.normal, lift);
        all = all && sees[0][j];
      }
      if (all) continue;
      for (int i = 1; i < kPoints; ++i) {
        for (int j = i + 1; j < kPoints; ++j) {
          sees[i][j] = sees[j][i] =
              footprintPointsSeeEachOther(surface, point[i], point[j], f.normal, lift);
        }
      }
      for (int i = 0; i < kPoints; ++i) {
        for (int j = 0; j < kPoints; ++j) score[i] += (i != j && sees[i][j]) ? 1 : 0;
      }
      int best = 0;
      for (int i = 1; i < kPoints; ++i) {
        if (score[i] > score[best]) best = i;
      }
      // The element's point stays unless another sees clearly more (two points more): on a
      // curved scan, segments grazing the surface decide single points either way, and the
      // same model in millimetres would anchor differently from it in metres.
      if (best == 0 || score[best] < score[0] + kAnchorMargin) continue;
      atlas.element_position[e] = point[best];
      atlas.element_face[e] = face[best];
      const glm::uvec3 tri = surface.flat.triangles[atlas.faces[face[best]].triangle];
      atlas.element_barycentric[e] = glm::vec2(triangleBarycentric(
          point[best], glm::dvec3(surface.flat.positions[tri.x]),
          glm::dvec3(surface.flat.positions[tri.y]), glm::dvec3(surface.flat.positions[tri.z])));
      ++moved;
    }
  });
  return moved.load();
}

}  // namespace penumbra
