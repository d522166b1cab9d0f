// What materials' textures and meshes' vertex colours give at a point of a triangle, for every
// method: per flattened triangle (flattenScene order), the reflectance, emission and coverage at
// a hit, whether a ray stops there (cut-outs), and the means over a part of a triangle that a
// radiosity element or an emitter needs (docs/algorithms.md, "Textures and cut-outs").
//
//  - At a hit, textures are read on their finest level (bilinear, or nearest for a nearest
//    sampler): a pixel's many samples integrate the texture over its footprint.
//  - Over a part of a triangle (an element's piece, an emitter's triangle), each texture is read
//    at up to 256 stratified points, one per texel of the finest level while that suffices, else
//    on a pyramid level coarse enough that the points do not alias its detail, so the mean takes
//    in every texel the part covers (texture.h, sampleTextureTrilinear). A cut-out's coverage
//    (alpha >= cutoff) is a step, so its mask is read on the finest level.
#pragma once

#include "penumbra/core/image.h"
#include "penumbra/scene/scene.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace penumbra {

class SurfaceTextures {
 public:
  SurfaceTextures() = default;
  // Over the scene's triangles in flattenScene order (the scene has passed validateScene).
  explicit SurfaceTextures(const Scene& scene);

  // Whether anything varies over a triangle anywhere (a texture or vertex colours). When not,
  // every method takes the materials' constants.
  bool any() const { return any_; }
  // Whether rays may pass through some triangle (Material::hasCutouts).
  bool hasCutouts() const { return cutouts_; }
  bool varies(uint32_t tri) const { return (flags_[tri] & kVaries) != 0; }
  bool isCutout(uint32_t tri) const { return (flags_[tri] & kCutout) != 0; }
  const Material& material(uint32_t tri) const { return materials_[material_ids_[tri]]; }

  // At the point of triangle `tri` with barycentrics b = (w1, w2).
  glm::vec3 reflectance(uint32_t tri, glm::vec2 b) const;
  glm::vec3 emission(uint32_t tri, glm::vec2 b) const;
  // The alpha the material's mode reads (1 for opaque materials).
  float alpha(uint32_t tri, glm::vec2 b) const;
  // Whether a ray meeting triangle `tri` at `b` stops there: always on an opaque material; on a
  // cut-out (kMask) where alpha >= cutoff; on kBlend with probability alpha, decided by `u`
  // (uniform in [0, 1), the caller's random number).
  bool stops(uint32_t tri, glm::vec2 b, float u) const;

  // What a GPU pass needs to answer stops() for cut-out triangle `tri` as the CPU does
  // (raytrace/gpu_cutouts.h): alpha(b) = factor(b) x lookup 0 x lookup 1, where the factor and
  // each lookup's image coordinates are linear in the barycentrics (given at the three corners)
  // and a lookup reads one channel of its texture on the finest level with its sampler. A lookup
  // that cannot vary (no UV set, an alpha channel that is 1 everywhere) is folded into the
  // factor.
  struct CutoutSource {
    struct Lookup {
      const TextureBinding* binding = nullptr;  // null: none
      int channel = 3;
      glm::vec2 st[3]{};
    };
    Lookup lookups[2];
    float factor[3] = {1.0f, 1.0f, 1.0f};
  };
  CutoutSource cutoutSource(uint32_t tri) const;

  // Means over a convex polygon of triangle `tri` given by its corners' barycentrics: the
  // reflected and emitted parts weighted by coverage (what a radiosity element of that area
  // reflects and emits), and the coverage itself. Without `factors`, the material's reflectance
  // and emission factors are left out (taken as 1): what the textures make of them.
  struct Mean {
    glm::dvec3 reflectance{0.0};  // mean of reflectance x coverage
    glm::dvec3 emission{0.0};     // mean of emission x coverage (W m^-2 sr^-1)
    double coverage = 1.0;
    // The coverage-weighted mean of the polygon's points, as barycentrics (w1, w2) of the
    // triangle: where its covered part's centre is (the polygon's centroid when it covers all
    // or nothing).
    glm::dvec2 covered_centroid{0.0};
  };
  Mean mean(uint32_t tri, std::span<const glm::vec2> polygon, bool factors = true) const;
  // The same over the whole triangle.
  Mean triangleMean(uint32_t tri, bool factors = true) const;

 private:
  enum : uint8_t { kVaries = 1, kCutout = 2, kOriginTop = 4, kColours = 8 };
  // A binding's image coordinates at barycentrics b of triangle tri; false when the mesh lacks
  // the binding's UV set (the texture's mean applies).
  bool imageCoordinates(uint32_t tri, const TextureBinding& binding, glm::vec2 b,
                        glm::vec2& st) const;
  glm::vec4 colour(uint32_t tri, glm::vec2 b) const;
  float coverageOf(const Material& m, uint32_t tri, glm::vec2 b, const glm::vec4& base) const;

  bool any_ = false;
  bool cutouts_ = false;
  std::vector<Material> materials_;
  std::vector<uint32_t> material_ids_;  // per triangle
  std::vector<uint8_t> flags_;          // per triangle
  // Per UV set any material reads: 3 corners per triangle (zeros where the mesh lacks it), and
  // per triangle whether the mesh has the set.
  std::vector<std::vector<glm::vec2>> corner_uvs_;
  std::vector<std::vector<uint8_t>> has_uvs_;
  std::vector<glm::vec4> corner_colours_;  // 3 per triangle when some mesh has colours
};

// Texture detail on a lightmap of outgoing radiance whose texels carry their footprint's mean
// reflectance (radiosity/radiosity_surface.h): the scene's textures, and per atlas texel that mean
// reflectance and the mean emitted radiance (gap-filled as the lightmap is). Where a surface
// varies, a pixel shows rho(x) (L - Le_mean) / rho_mean + Le(x): the irradiance the lightmap
// holds (divided out of its mean albedo) times the texture's albedo at the pixel, plus the
// texture's emission there. `textures` also gives the view rays' cut-outs.
struct LightmapDetail {
  std::shared_ptr<const SurfaceTextures> textures;
  Image mean_reflectance;
  Image mean_emission;
};

}  // namespace penumbra
