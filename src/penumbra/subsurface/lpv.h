// Subsurface light propagation volumes (Børlum, Christensen, Kjeldsen, Mikkelsen, Noe, Rimestad,
// Mosegaard 2011, SSLPV): subsurface scattering for translucent objects that may deform and
// change topology every frame, lit by moving lights, with no precomputation. Each mesh with a
// translucent material (a `subsurface` block, scene/material.h) gets a light propagation volume
// (subsurface/lpv_volume.h) around it; every frame:
//
//  - voxelisation: the mesh as it is now sorted into inside, boundary and outside cells;
//  - injection (sec. 3.1, subsurface/lpv_inject.cpp): per light a reflective shadow map of
//    rsm_resolution^2 texels over the object, here traced through the Ray Engine (closest hits:
//    other objects shadow it): at each texel that sees the object's front, the flux
//    Phi_p = I Delta w_p (Delta w_p the texel's solid angle, the paper's
//    4 alpha tan^2(FOV / 2) cos^3 theta_p / (N_x N_y); a directional light's map is orthographic,
//    Phi_p = E times the texel's area) enters as a virtual point light with intensity
//    (1 / pi) T Phi_p max(0, w_t . w) about the refracted direction w_t (eq. 1, T the Fresnel
//    transmittance), projected on the two SH bands and summed into the boundary cell that holds
//    the texel's surface point; emitting surfaces and the environment through gathered points of
//    the object's surface;
//  - propagation (sec. 3.2): `steps` steps through the object's cells, absorbing and scattering;
//    the accumulation grid sums the propagation grid after every step but the first
//    `skip_steps` (sec. 4: fewer flickers as lights and meshes move); on the CPU (oneTBB) or,
//    after useGpu(), on the GPU (subsurface/lpv_gl.h), the same result to float rounding.
//
// The view (sec. 3.3): a translucent surface point shows T(w_o) L_i, L_i the area-light radiance
// of the accumulated intensity at the point (eq. 5-7, the cell's cross-section A = dx^2), the
// coefficients interpolated trilinearly between the object's cells around it (the paper takes
// the cell that holds the point, which shows the grid's blocks); opaque surfaces their direct
// light with shadow rays (rho / pi E V), emitters their radiance, misses the environment. The
// boundary's specular reflection is not part of the model (as in the dipole method).
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/raytrace/ray_engine.h"
#include "penumbra/scene/camera.h"
#include "penumbra/scene/scene.h"
#include "penumbra/subsurface/lpv_volume.h"

#include <cstdint>
#include <memory>
#include <vector>

namespace penumbra {

class GlLpv;

struct LpvOptions {
  int grid = kLpvDefaultGrid;  // cells along each object's longest side, [4, kLpvMaxGrid]
  int steps = 8;               // propagation steps (Table 1: 8 and 32)
  int skip_steps = 2;          // first steps left out of the accumulation (sec. 4)
  int rsm_resolution = 256;    // injection texels per side of each light's map (sec. 5: 256^2)
  // Emitting surfaces and the environment inject through points of each object's surface (not in
  // the paper: subsurface/lpv_inject.cpp), `surface_rays` cosine-distributed rays each; redone
  // only when the geometry, the emissions or the environment change. Scenes without either
  // skip it.
  int surface_samples = 16384;  // [0, kLpvMaxSurfaceSamples]
  int surface_rays = 16;        // [0, 256]
};
inline constexpr int kLpvMaxSurfaceSamples = 1 << 20;

// Per-stage wall-clock seconds of one frame (Table 1's columns, with the voxelisation).
struct LpvFrameTimes {
  double voxelise = 0.0;  // and the Ray Engine's rebuild for the moved geometry
  double inject = 0.0;    // the reflective shadow maps and the virtual point lights
  double propagate = 0.0;
  double shade = 0.0;       // the image
  uint64_t rsm_texels = 0;  // texels that injected light
};

// One translucent mesh's volume.
struct LpvObject {
  uint32_t mesh = 0;
  uint32_t material = 0;
  Subsurface medium;
  LpvGrid grid;
  std::vector<LpvCell> cells;
  LpvMedium cell_medium;
  LpvField surroundings;  // the emitters' and the environment's virtual point lights
  LpvField injected;      // the virtual point lights of this frame
  LpvField accumulated;   // the accumulation grid
  // Kept from frame to frame while the geometry stays: the cells and factors of the
  // propagation, and its fields (zero outside the object's cells).
  LpvTransfer transfer;
  LpvField propagation[2], sent;
};

class LpvSolver {
 public:
  // Checks the options and that some mesh has a translucent material (an input error naming
  // the scene otherwise), and that the grids fit in memory whatever shape the meshes take later
  // (grid^3 cells each at most). The scene must have passed validateScene.
  static Expected<LpvSolver> build(const Scene& scene, const LpvOptions& options);

  // One frame for the scene as it is now (same meshes, positions and lights may have moved):
  // voxelisation, injection, propagation. When the geometry is the last frame's (the same
  // vertices and triangles), its voxelisation and Ray Engine are kept: only the lights moved.
  // Each grid follows its mesh: `grid` cells along the mesh's longest side. Fails only on the
  // GPU (out of device memory).
  Expected<LpvFrameTimes> update(const Scene& scene);

  // From now on the propagation and accumulation run on the GPU (subsurface/lpv_gl.h), the
  // injection and the view stay here. Needs a current OpenGL 4.5 context on the calling thread,
  // for this call and every later update. Fails (as a value) when a shader does not compile.
  Status useGpu();
  bool onGpu() const { return gpu_ != nullptr; }

  // The image of the last update's state from `camera` (w x h, spp samples per pixel, stratified
  // (raytrace/camera_rays.h: pixelJitter) from `seed`); adds its seconds to times->shade when
  // given. The camera's samples are traced once and kept while the geometry, the camera and the
  // image settings stay (a moving light costs only the lookups and the opaque surfaces' shadow
  // rays).
  Image render(const Scene& scene, const Camera& camera, int width, int height, int spp,
               uint64_t seed, LpvFrameTimes* times = nullptr);

  // Eq. 7 at a surface point of object k with outward normal n: the incident area-light
  // radiance per channel (W m^-2 sr^-1) before the view's Fresnel transmittance.
  glm::dvec3 incidentRadiance(size_t k, const glm::dvec3& p, const glm::dvec3& n) const;

  const std::vector<LpvObject>& objects() const { return objects_; }
  const LpvOptions& options() const { return options_; }
  // Bytes of the grids (propagation, accumulation, injection, medium, cells) of every object.
  uint64_t gridBytes() const;

 private:
  // A camera sample of the view: a translucent point (object + 1, outward normal, F_t(w_o) /
  // spp), or an opaque one (object 0, the normal of the side seen, rho / spp in `factor`).
  struct ViewSample {
    uint32_t pixel;
    uint32_t object;
    glm::vec3 point, normal, factor;
  };
  struct ViewCache {
    bool valid = false;
    uint64_t geometry = 0;
    Camera camera;
    int width = 0, height = 0, spp = 0;
    uint64_t seed = 0;
    std::vector<ViewSample> samples;  // in pixel order
    std::vector<glm::vec3> emitted;   // per pixel: emitters and the environment, / spp
  };

  LpvOptions options_;
  uint64_t geometry_ = 0;  // counts changes of the geometry
  bool stale_ = false;     // the volumes must be made again (the device changed)
  ViewCache view_;
  std::vector<LpvObject> objects_;
  FlatTriangles flat_;
  std::vector<uint32_t> triangle_object_;  // per flattened triangle: its object + 1, 0 for none
  RayEngine engine_;
  double lift_ = 0.0;
  std::shared_ptr<GlLpv> gpu_;  // the GPU's propagation, when taken

  glm::vec3 environment_{0.0f};       // what the surroundings' injection saw
  std::vector<glm::vec3> emissions_;  // per material

  // Sec. 3.1: the lights' reflective shadow maps on top of the surroundings' injection.
  void inject(const Scene& scene, LpvObject& object, uint32_t index, uint64_t* texels);
  // The emitters' and the environment's light into object.surroundings.
  void injectSurroundings(const Scene& scene, LpvObject& object, uint32_t index);
  static bool hasSurroundings(const Scene& scene);
  // The geometry changed: the Ray Engine, the triangles' objects, every object's grid,
  // voxelisation, medium and fields.
  Status rebuild(const Scene& scene, FlatTriangles flat);
  // Sec. 3.2: the steps and the accumulation for every object.
  Status propagate();
};

}  // namespace penumbra
