// The surface every radiosity method solves on: the scene's faces laid out in the chart atlas
// (geometry/chart_atlas.h), whose occupied texels are the elements, with the multiresolution
// hierarchy over them (geometry/surface_hierarchy.h), each element's material, and the Ray Engine
// over the scene's triangles for visibility. Matrix radiosity (clusters of a cut as its
// unknowns), progressive radiosity (clusters as shooters) and the methods to come share it, so
// they bake to the same lightmap layout.
//
//  - Two-sided surfaces (Material::two_sided) have elements on each side; an element emits
//    (front faces only, E = pi * emitted radiance) and reflects on its own side.
//  - Shading normals: the mesh's own vertex normals, or generated ones (geometry/
//    shading_normals.h), interpolated at each element's point, as Wallner interpolates normals
//    (sec. 3); culling and shadow rays use the faces' own normals.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/core/rng.h"
#include "penumbra/geometry/chart_atlas.h"
#include "penumbra/geometry/surface_hierarchy.h"
#include "penumbra/raytrace/lights.h"
#include "penumbra/raytrace/ray_engine.h"
#include "penumbra/scene/scene.h"
#include "penumbra/scene/surface_textures.h"

#include <glm/vec3.hpp>

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

namespace penumbra {

// The texel density that gives about `elements` elements on the scene's faces (a two-sided
// triangle's area counts twice): sqrt(elements / area); 0 when the scene has no area.
double texelDensityFor(const Scene& scene, uint32_t elements);

// Lightmap texels (elements, both sides of two-sided surfaces) when the caller names no density:
// a room of a few hundred charts (the bunny scan, a teapot, quads) at this count reaches 1% unshot
// power with progressive radiosity in about 12 s on two cores and agrees with the path tracer to
// 1% (docs/performance.md).
inline constexpr uint32_t kDefaultLightmapElements = 40000;

// How fine the lightmap is, as a user says it: a density, an atlas size, or a texel count.
struct LightmapResolution {
  std::optional<double> texel_density;           // texels per metre
  std::optional<int> size;                       // an N x N atlas at the largest density that fits
  uint32_t elements = kDefaultLightmapElements;  // otherwise about this many texels
  bool asset_uvs = false;                        // ChartAtlasOptions::asset_uvs
};

// The texel density of the scene's normal maps on their surfaces (texels per metre, the mean
// over the mapped triangles weighted by area); 0 without normal maps. The automatic lightmap
// density (LightmapResolution::elements) rises towards it, by at most a factor of 2, so the
// lightmap follows its normal maps (Wallner sec. 3.3).
double normalMapTexelDensity(const Scene& scene);

// The atlas options for a resolution (the charts' own options at their defaults). Fails for a
// density that is not a positive number or a scene without area.
Expected<ChartAtlasOptions> lightmapAtlasOptions(const Scene& scene, const LightmapResolution& r);
// The scene's meshes' second UV sets (TEXCOORD_1) as the atlas's asset layout
// (geometry/asset_charts.h); none when no mesh has one.
std::optional<AssetLightmapUvs> assetLightmapUvs(const Scene& scene);
// The texels a resolution will give, about (for memory checks before building).
uint64_t expectedLightmapElements(const Scene& scene, const LightmapResolution& r);

struct RadiositySurface {
  ChartAtlas atlas;
  SurfaceHierarchy hierarchy;
  FlatTriangles flat;
  RayEngine engine;
  Bounds3 bounds;
  double lift = 0.0;  // shadow-ray end points are lifted off their surfaces by this (m)
  // Elements whose point moved to the side of their footprint that geometry crossing it does not
  // cut off (radiosity/texel_footprint.h).
  size_t anchored = 0;
  // The charts' gap fill around the elements' texels, planned once for radianceImage.
  ChartGapPlan gap_plan;
  // Which sides of the flattened triangles have elements: has_side[2 t + back]; and the face
  // laid out there (-1: none).
  std::vector<uint8_t> has_side;
  std::vector<int32_t> side_face;
  // Per element.
  std::vector<glm::dvec3> reflectance;
  std::vector<glm::dvec3> emission;  // W m^-2 (pi L_e on front faces of emissive materials)
  std::vector<glm::dvec3> shading_normal;
  std::vector<uint32_t> material;  // Scene::materials index
  double total_area = 0.0;         // m^2, both sides of two-sided surfaces
  // Textures, vertex colours and cut-outs (null when the scene has none; the engine's cut-out
  // filter reads it too), and per element what they make of the material's factors: the mean
  // over the element's pieces of texture x vertex colour x coverage for reflectance and of
  // texture x coverage for emission (SurfaceTextures::mean); empty when null.
  std::shared_ptr<const SurfaceTextures> textures;
  std::vector<glm::dvec3> texture_reflectance;
  std::vector<glm::dvec3> texture_emission;
  // Per element, the share of its area that is there at all (cut-outs: what a ray arriving at
  // it stops on); empty when every element covers its area. Light arriving at an element is
  // intercepted in this share, the rest passes on to what lies behind; the power books and the
  // closure of rows and shots count it so.
  std::vector<double> coverage;
  double coverageOf(size_t e) const { return coverage.empty() ? 1.0 : coverage[e]; }
  // The scene's openings when one is glazed (scene/sky.h), else empty: a lamp's or the sun's
  // light reaching an element through glazing is cut by its transmittance at that incidence.
  std::vector<Opening> glazing;

  // Builds the atlas over the scene's faces (the scene must have passed validateScene).
  static Expected<RadiositySurface> build(const Scene& scene, const ChartAtlasOptions& atlas,
                                          bool shading_normals);

  size_t elementCount() const { return atlas.elementCount(); }
  // Sets reflectance and emission from the materials (relighting: the geometry stays): each
  // material's factors times the element's texture means.
  void applyMaterials(std::span<const Material> materials);
  // What the view needs to show the textures' detail over a lightmap of this surface
  // (render/lightmap_view.h, scene/surface_textures.h); null when the scene has no textures or
  // cut-outs.
  std::shared_ptr<const LightmapDetail> lightmapDetail() const;
  // Fills texture_reflectance, texture_emission and coverage (textures is set), and moves the
  // point of each element a cut-out covers in part to the centre of its covered part.
  void integrateTextures();
  // Perturbs the shading normals of the elements on the front of materials with a normal map
  // (Wallner sec. 3.3; scene/material.h); `corner_normals` as cornerShadingNormals gives them.
  void applyNormalMaps(const Scene& scene, std::span<const glm::vec3> corner_normals);

  // Direct irradiance from the lights at each element's point (W m^-2, raytrace/lights.h),
  // with one Ray Engine shadow ray per element and light when `visibility`; rays traced are
  // added to *rays.
  std::vector<glm::dvec3> lightIrradiance(std::span<const Light> lights, bool visibility,
                                          uint64_t* rays = nullptr) const;
  // The same at any points on the surface (receivers: radiosity/progressive_receivers.h), with
  // their face and shading normals.
  std::vector<glm::dvec3> lightIrradianceAt(std::span<const Light> lights, bool visibility,
                                            std::span<const glm::dvec3> positions,
                                            std::span<const glm::dvec3> normals,
                                            std::span<const glm::dvec3> shading_normals,
                                            uint64_t* rays = nullptr) const;
  // The shadow ray from `p` (face normal `ng`, lifted off the surface) towards a light sample.
  Ray shadowRayToLight(const LightSample& sample, const glm::dvec3& p, const glm::dvec3& ng) const;

  // The element a ray with direction `dir` that hit triangle t at barycentrics (u, v) landed on
  // (the side it arrived at, its texel in the atlas, or the nearest element of that chart
  // within one texel where the texel is a border one); -1 on a side without elements.
  int32_t elementAtHit(int32_t t, float u, float v, const glm::vec3& dir) const;
  // Whether every ray of `rays` hits a face that has elements (none escapes to the outside or
  // reaches a black back face of a one-sided surface).
  bool allHitElements(const RayBatch& rays) const;
  // `count` cosine-distributed rays from points of elements [first, last) chosen by area
  // (deterministic for a seed), tested with allHitElements: whether that part of the surface
  // sees only elements.
  bool seesOnlyElements(uint32_t first, uint32_t last, int count, uint64_t seed) const;

  // Outgoing radiance B / pi per atlas texel from B per element: kInside texels hold their
  // element's value, the chart's other footprint and padding texels the mean of filled
  // neighbours of the same chart (in rounds, fillChartGaps), kEmpty texels zero.
  Image radianceImage(std::span<const glm::dvec3> radiosity) const;
  Image radianceImage(std::span<const glm::vec3> radiosity) const;
};

}  // namespace penumbra
