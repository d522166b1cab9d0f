// A scene: world-space meshes, their materials, delta lights and an optional camera.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/scene/calculation_grid.h"
#include "penumbra/scene/camera.h"
#include "penumbra/scene/light.h"
#include "penumbra/scene/material.h"
#include "penumbra/scene/mesh.h"
#include "penumbra/scene/sky.h"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

namespace penumbra {

struct Scene {
  std::string source;  // file path or "builtin:NAME", for messages
  std::vector<Mesh> meshes;
  std::vector<Material> materials;
  std::vector<Light> lights;
  std::optional<Camera> camera;
  // Uniform environment: the radiance (W m^-2 sr^-1, RGB, finite and non-negative) arriving from
  // every direction the scene does not block, as from an infinitely distant sphere around it.
  // Zero (none) by default. The path tracer gathers it on rays that leave the scene, radiosity at
  // its elements (radiosity/outside_light.h); furnace and albedo tests light a scene with it.
  glm::vec3 environment{0.0f};
  // Per-method settings from the scene file ("settings": {"pathtrace": {...}}), applied before
  // command-line options, which win.
  nlohmann::json settings = nlohmann::json::object();
  // Daylight ("sky", scene/sky.h): a CIE standard general sky, the sun's position (its beam, when
  // given, is a directional light in `lights`) and the ground outside. Rays that leave the scene
  // see it instead of `environment`.
  std::optional<Sky> sky;
  // Openings through which the sky is sampled ("openings"): windows and roof lights, glazed or
  // not; not geometry.
  std::vector<Opening> openings;
  // Calculation objects the scene file declares ("calculation", io/calculation_objects.h):
  // where lux are reported. They take no part in the light.
  std::vector<CalculationGrid> calculation;
  // Things a user should know about what was loaded (ignored features, degenerate triangles).
  std::vector<std::string> warnings;

  size_t triangleCount() const;
  size_t vertexCount() const;

  // Appends `other`'s meshes, materials, lights and warnings; material ids are re-based. The
  // environment becomes the per-channel maximum of the two (so a mesh file, which has none,
  // never removes the scene's).
  void append(Scene other);
};

// All meshes as one triangle list, in scene order: triangle i of the result is the i-th
// triangle of the scene (the numbering `penumbra trace` reports).
struct FlatTriangles {
  std::vector<glm::vec3> positions;
  std::vector<glm::uvec3> triangles;
  std::vector<uint32_t> material_ids;
};
FlatTriangles flattenScene(const Scene& scene);
// The summed area of the triangles (m^2).
double surfaceArea(const FlatTriangles& flat);
// The centre of the bounding box of the scene's vertices.
glm::vec3 sceneCentre(const Scene& scene);
// The scene's UVs per flattened triangle corner (corner k of triangle t at 3 t + k, flattenScene
// order), zeros for meshes without UVs; `any` says whether some mesh had them.
std::vector<glm::vec2> flattenSceneUvs(const Scene& scene, bool& any);

// The farthest a vertex may lie from the origin, in metres: beyond it areas and squared
// distances overflow single precision within a few products (a mesh scaled by 1e30 rendered
// black).
inline constexpr float kMaxCoordinate = 1e9f;

// Checks what every consumer relies on: finite positions within kMaxCoordinate of the origin,
// normals and UVs, indices in range,
// material ids in range, reflectance in [0, 1], non-negative finite emission and environment,
// valid subsurface media. Degenerate (zero-area) triangles are kept, so that triangle indices
// still follow the file, but are counted in a warning; a mesh made only of degenerate triangles
// is an error. Then emitters drawn on another surface are lifted off it
// (scene/coplanar_emitters.h), with a warning.
Status validateScene(Scene& scene);
// validateScene's checks alone, without lifting emitters.
Status checkScene(Scene& scene);

// The Lambertian reflectance a method without specular transport (radiosity, sss, lpv) sees on a
// mirror or glass (Material::scattering): a mirror keeps its reflectance (the energy it returns,
// spread diffusely); glass becomes an opaque surface of its normal-incidence Fresnel reflectance
// ((n - 1) / (n + 1))^2 (what it reflects; the light it would transmit is lost). The scene
// readers store it in Material::reflectance; for a diffuse material it is `reflectance` itself.
glm::vec3 diffuseStandIn(const Material& m);
// One line per mirror or glass material, saying what `method` (a method without specular
// transport) sees instead, and one when the scene has a sky that `method` does not take; empty
// when there is nothing to say.
std::vector<std::string> diffuseStandInWarnings(const Scene& scene, const std::string& method);

// Whether light enters the scene from somewhere other than its surfaces: a light, a sky or a
// uniform environment.
bool hasLightOtherThanSurfaces(const Scene& scene);
// The error every method gives a scene that emits no light at all (no light, sky or environment,
// and no emitting surface that is there: a cut-out emitter whose texels are all holes emits
// nothing), naming `method`.
Error noLightError(const Scene& scene, const std::string& method);

// Every length of `scene` (geometry, light positions, the camera, openings, calculation objects)
// times `metres_per_unit`: a scene read in another unit than the metre, in metres.
void scaleScene(Scene& scene, double metres_per_unit);

// A camera that frames the scene's bounding box from the front when it has none: from +z looking
// down -z with +y up, where glTF 2.0 (sec. 3.4), OBJ files from Blender and the Stanford scans put
// a model's front, as glTF viewers frame it.
Camera defaultCamera(const Scene& scene);

}  // namespace penumbra
