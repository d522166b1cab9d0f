// Materials: Lambertian by default, or a perfect mirror or smooth glass (Material::scattering).
// Reflectance is the hemispherical reflectance rho in [0, 1) per RGB
// channel (the BRDF is rho / pi); emission is the radiance leaving the front face
// (W m^-2 sr^-1, the side the counter-clockwise winding faces). Surfaces reflect on both sides
// unless `two_sided` is false (glTF's doubleSided = false, or "two_sided": false in a JSON
// scene): then the back face is black in every method: it reflects and emits nothing, and the
// radiosity methods give it no elements.
#pragma once

#include "penumbra/core/image.h"
#include "penumbra/scene/texture.h"

#include <glm/vec3.hpp>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

namespace penumbra {

struct MediumGrid;

// A translucent, homogeneous medium filling the closed surface a material covers (subsurface
// scattering, scene/media.h): the reduced scattering and absorption coefficients of the
// diffusion approximation (Jensen et al. 2001) and the index of refraction of its boundary.
struct Subsurface {
  glm::dvec3 sigma_s_prime{0.0};  // reduced scattering coefficient sigma_s' per metre
  glm::dvec3 sigma_a{0.0};        // absorption coefficient per metre
  double eta = 1.3;               // index of refraction relative to the outside
  double g = 0.0;                 // Henyey-Greenstein mean cosine (sigma_s' = sigma_s (1 - g))
  std::string preset;             // the measured material it comes from, if any ("marble")
  // How the medium varies over the mesh's bounding box (scene/heterogeneous_media.h): a
  // procedural pattern over these coefficients ("veins", "layers"), or a grid read from a file.
  // Only the lpv method uses it; the others take the coefficients above.
  std::string pattern;
  std::shared_ptr<const MediumGrid> grid;
};

// How a surface scatters the light that reaches it. The specular kinds are delta BSDFs (Whitted
// 1980; PBRT 4th ed. sec. 9.2-9.5): only the path tracer and the whitted and photons methods
// follow them. The radiosity, sss and lpv methods see a Lambertian stand-in of `reflectance`
// instead, which the scene readers set (docs/scene-format.md) and the methods warn about
// (diffuseStandInWarnings, scene/scene.h).
enum class Scattering : uint8_t {
  kDiffuse,     // Lambertian of `reflectance` (with a medium behind it when `subsurface` is set)
  kMirror,      // perfect specular reflection of `specular` per channel
  kDielectric,  // smooth glass of index `ior` around the closed mesh's inside: exact Fresnel
                // reflection and refraction, total internal reflection included; `specular`
                // filters the light once as it enters (1 = clear glass)
};

// How a surface covers what lies behind it (glTF 2.0 sec. 3.9.4, alphaMode): every method's rays
// and raster passes see through the uncovered part (docs/algorithms.md, "Cut-outs").
enum class AlphaMode : uint8_t {
  kOpaque,  // alpha is ignored: the surface covers everything
  kMask,    // a cut-out: covered where alpha >= alpha_cutoff, a hole elsewhere
  kBlend,   // partial coverage: light passes with probability 1 - alpha
};

struct Material {
  std::string name;
  glm::vec3 reflectance{0.8f};
  glm::vec3 emission{0.0f};
  bool two_sided = true;
  // Set for translucent materials: light enters, scatters inside and leaves elsewhere. The path
  // tracer (a smooth Fresnel boundary around a random walk in the medium) and the `sss` method
  // (the dipole) model the medium, and both ignore `reflectance` on such a surface; the other
  // methods, which know no media, treat it as a Lambertian surface of `reflectance`.
  // Emission, if any, still leaves the front face. The mesh must be closed and wound outwards:
  // the medium is behind the front face.
  std::optional<Subsurface> subsurface;
  // A tangent-space normal map (Wallner sec. 3.3; glTF normalTexture) on the mesh's UVs, its
  // values as stored (no sRGB decoding): n = normalize((2 r - 1) s, (2 g - 1) s, 2 b - 1) with
  // s = normal_scale, in the frame of the corner tangents (geometry/tangents.h). The radiosity
  // methods take the perturbed normal for the receiver's cosine; the path tracer keeps the
  // geometric normal (see docs/algorithms.md). Null: none.
  std::shared_ptr<const Image> normal_map;
  std::string normal_map_source;  // the file, for messages
  float normal_scale = 1.0f;

  // Textures (scene/texture.h; docs/scene-format.md), each read through its UV set, sampler and
  // transform. `reflectance_texture` multiplies `reflectance` (glTF baseColorTexture times
  // baseColorFactor, MTL map_Kd times Kd) and its alpha multiplies `alpha`;
  // `emission_texture` multiplies `emission` (glTF emissiveTexture, MTL map_Ke). A mesh's
  // vertex colours (Mesh::colors) multiply reflectance and alpha too.
  std::optional<TextureBinding> reflectance_texture;
  std::optional<TextureBinding> emission_texture;
  // Coverage from a texture of its own (MTL map_d): its alpha channel when the file has one,
  // else its first channel, as stored; multiplies `alpha`.
  std::optional<TextureBinding> coverage_texture;
  float alpha = 1.0f;  // coverage factor: glTF baseColorFactor's alpha, MTL d
  // Whether reflectance_texture's alpha multiplies `alpha` (glTF: yes; MTL: no, map_d does).
  bool alpha_from_reflectance = true;
  AlphaMode alpha_mode = AlphaMode::kOpaque;
  float alpha_cutoff = 0.5f;  // kMask: covered where alpha >= alpha_cutoff

  // An unlit surface (glTF KHR_materials_unlit): seen by the camera in its own colour whatever
  // light falls on it, and outside the light transport. The reader puts that colour in
  // `emission` and `emission_texture` and makes `reflectance` black: every method's view shows
  // the emission at a camera hit, while light sampling, radiosity's emission and the path
  // tracer's later bounces leave an unlit surface's out. It reflects nothing and blocks light as
  // any surface does.
  bool unlit = false;

  Scattering scattering = Scattering::kDiffuse;
  glm::vec3 specular{1.0f};  // mirror reflectance, or glass transmittance (see Scattering)
  float ior = 1.5f;          // glass: index of refraction relative to the outside

  bool isEmissive() const { return emission.x > 0.0f || emission.y > 0.0f || emission.z > 0.0f; }
  bool isTranslucent() const { return subsurface.has_value(); }
  bool isSpecular() const { return scattering != Scattering::kDiffuse; }
  bool isTextured() const { return reflectance_texture || emission_texture || coverage_texture; }
  // Whether rays may pass through some of the surface.
  bool hasCutouts() const {
    if (alpha_mode == AlphaMode::kOpaque) return false;
    if (coverage_texture) return true;
    if (alpha_from_reflectance && reflectance_texture && reflectance_texture->texture->hasAlpha()) {
      return true;
    }
    return alpha_mode == AlphaMode::kMask ? alpha < alpha_cutoff : alpha < 1.0f;
  }
};

}  // namespace penumbra
