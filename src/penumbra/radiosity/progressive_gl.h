// Progressive refinement radiosity on the GPU (OpenGL 4.5), Wallner sec. 3 and 3.1: the twin of
// the CPU solver ProgressiveRadiosity (progressive.h), built from one and working on the same
// chart atlas and the same elements (the kInside texels, with the CPU's exact-coverage points,
// normals, areas, reflectances and pieces uploaded per element), so that the two can hand the
// state back and forth (download() / upload(), ProgressiveRadiosity::state() / setState()). It
// runs the CPU's flat substructuring (the shooter's clusters of one level of the hierarchy,
// ProgressiveRadiosity::flatLevel; shooter_top_points, the CPU's hierarchical refinement, is not
// used here), each point at the centroid of its power as on the CPU, with the faces' own normals
// (ProgressiveOptions::shading_normals is not used here either). Point, spot and directional lights
// shoot on the CPU first (create() refuses a state whose lights have not shot).
//
//  - Textures (sec. 3): the radiosity B and residual dB atlases, RGBA32F of the atlas's size,
//    alpha = 1 on occupied (kInside) texels; an "incident" RGBA32F target that gathers an
//    iteration's irradiance; one depth texture and one triangle-id texture (R32UI) holding the
//    depth maps of a batch of up to 4 x 4 shooter points (visibility_resolution^2 per point).
//  - Shooter selection (sec. 3) on the GPU: the residual power of every shooter (a cluster of
//    the hierarchy, a contiguous range of elements), the sum over its occupied texels of
//    luminance(dB) (0.3 R + 0.59 G + 0.11 B) times the element area (the paper's mipmap
//    reduction over alpha = 1 texels), in double and in the CPU's order, then a max reduction in
//    one work group; only the winner (16 bytes) is read back, so the two pick the same shooter
//    from the same state (ProgressiveGl.SelectsTheSameShootersAsTheCpu).
//  - Shooting, per batch of shooter points (the CPU's clusters of one level, with summed area
//    and area-weighted mean position; their dB sums by a compute pass, read back for the books),
//    through the hemispherical gather it shares with stochastic radiosity (hemisphere_gl.h):
//     1. depth pass (Algorithm 1): the scene's triangles through each point's hemispherical
//        stereographic projection (around the shooter's mean normal) into its tile of the depth
//        texture, with the nearest triangle's id; triangles are drawn as k x k sub-triangles
//        (k = ceil(the longest edge in atlas texels / tessellation_texels)), each clipped against
//        the shooter's plane;
//     2. receiver pass: every element drawn as one point at its texel's centre (exactly one
//        fragment per element; the paper rasterises receiver triangles through their UVs, whose
//        fragments of a texel would all compute the same value). The fragment shader
//        back-projects the element's point into each point's depth map through the sub-triangle
//        the depth pass rasterised (the paper's "same error") and compares depths (Fig. 3;
//        where the texel sees the element's own or a touching chart, the segment is tested
//        exactly against the triangles of the 3 x 3 neighbourhood that are nearer); if visible
//        it adds eq. 2's disc form factor times the point's dB, nearer than kProgressiveFar
//        point sizes Lambert's form factor to the point's pieces (uploaded per point) times
//        its mean dB, and for pairs closer than kProgressiveNear sizes Lambert's form factor to
//        each member element's pieces, in a second pass over the charts that can be that
//        close: the CPU's kernels. The sum goes into the incident target by additive
//        blending.
//    Then a compute pass applies B += rho E_in, dB += rho E_in (scaled when the shot is closed,
//    ProgressiveRadiosity::shotClosed, as on the CPU), zeroes the shooter's dB, and reduces
//    E_in * area per work group in double.
//  - Energy books (W per channel) exactly as the CPU keeps them; emitted = absorbed + unshot +
//    escaped holds after every iteration, with the unshot power recomputed from the GPU's float
//    dB, to 3e-8 relative.
//  - Post-process (sec. 3.1): radianceImage() writes B / pi per occupied texel, then in
//    `gap_fill_passes` ping-pong passes (2, the paper's) gives every unoccupied texel next to
//    filled texels of the same chart their mean, so bilinear lookups inside a chart never read
//    unlit texels. Its kInside and kBorder texels agree with the CPU's radianceImage of the same
//    state to 3e-7.
//
// Agreement with the CPU, measured on llvmpipe (tests/radiosity/progressive_gl_test.cpp):
//  - furnace, 24 iterations from the same sequence: per-element relative RMS 2.7e-7; one shot:
//    gains within 1.7e-6; converged on the GPU: every element within 0.17% of E / (1 - rho).
//  - Cornell box (25 texels/m, level 1, 512^2 depth maps), 30 iterations along the CPU's
//    sequence: relative RMS 2.6e-3 over the front faces, the largest differences on the floor
//    at the corner of a box's base and the ceiling over the light (0.8 mm gap), where the depth
//    maps and the CPU's rays part; a rendered image (1,500 elements) 8.6% RMS from the CPU's
//    (tests/app/cli_test.cpp). The red wall's shot on the ceiling along it (the horizon of its
//    points' maps) within 0.01% of the CPU's.
//  - At the defaults the rendered Cornell box is 0.996 of the path tracer, every 4 x 4 block
//    within 2.3% (the CPU's hierarchical scheme: 0.9955, 2.3%).
//
// The shaders avoid variable-length arrays and put work behind loops rather than branches where
// a SIMD rasteriser would otherwise run both sides (llvmpipe, which the tests run on, does).
//
//  - Receivers and adaptive subdivision (sec. 4, radiosity/progressive_receivers.h), as on the
//    CPU: the receiver pass draws the receivers (clusters of elements in the element layout, at
//    a point on the surface) at one texel each; their irradiance is read back, interpolated to
//    the elements and written to every element's texel before the resolve pass. Before a
//    shooter's first shot the samples pass draws every element once per batch against the
//    batch's depth maps: the visibility counts n_r, n_v the paper's three occlusion-query passes
//    give per triangle, here per texel and read back (4 bytes per element) for the split, which
//    runs on the CPU on the same hierarchy and criteria as the CPU solver's.
//
// Limitations: no occlusion queries (sec. 3 uses them to skip receivers that see nothing of the
// shooter, sec. 4 to count fragments; the depth maps answer both, per texel); the iteration's
// `rays` is 0 (no rays are traced); needs a current OpenGL 4.5 context on the calling thread.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/gpu/objects.h"
#include "penumbra/radiosity/hemisphere_gl.h"
#include "penumbra/radiosity/progressive.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

namespace penumbra {

// What the GPU path runs, from a caller's options: the paper's flat substructuring
// (shooter_top_points = 0) with the faces' own normals (shading_normals = false); the level is
// chosen once the elements are known (gpuShooterLevel).
ProgressiveOptions gpuProgressiveOptions(ProgressiveOptions options);

// The flat substructuring's level for the GPU: the coarsest at which an average shooter of
// `cpu` still has at least `points` clusters (sec. 3: one mip level for every shooter), at most 8.
int gpuShooterLevel(const ProgressiveRadiosity& cpu, int points);

// ---- GPU layouts (std430), mirrored in shaders/radiosity/progressive_layout.glsl (the
// elements', triangles' and batch points' in hemisphere_gl.h) ----

// A shooter (ProgressiveRadiosity's): its elements [element_first, + element_count), 8 bytes.
struct GpuShooter {
  uint32_t element_first;
  uint32_t element_count;
};
static_assert(sizeof(GpuShooter) == 8);

// A shooter point's elements, [member_first, + member_count) (a cluster of the hierarchy is a
// contiguous range): 8 bytes.
struct GpuShooterPoint {
  uint32_t member_first;
  uint32_t member_count;
};
static_assert(sizeof(GpuShooterPoint) == 8);

struct GpuSelection {  // 16 bytes
  double power;
  uint32_t shooter;
  uint32_t pad;
};
static_assert(sizeof(GpuSelection) == 16 && offsetof(GpuSelection, shooter) == 8);

struct GpuResolveSums {  // 96 bytes
  double arrived[4];
  double absorbed[4];
  double reflected[4];
};
static_assert(sizeof(GpuResolveSums) == 96 && offsetof(GpuResolveSums, reflected) == 64);

// ---- The solver ----

class GlProgressive {
 public:
  static constexpr uint32_t kNoShooter = ProgressiveRadiosity::kNoShooter;

  // Uploads the atlas, the elements and the CPU solver's current state (B, dB, books,
  // iterations, receivers), and takes its options (shooter_level, visibility, convergence,
  // max_iterations, receivers and adaptive subdivision). With coarse receivers or `adaptive`
  // the GPU solver keeps a reference to `cpu`'s surface (the hierarchy it splits receivers in):
  // `cpu` must outlive it, unmoved. Fails, as an input error naming the bytes, before allocating
  // when a texture exceeds the device's maximum texture or renderbuffer size (or
  // `gl_options.max_texture_size`), a buffer its shader storage block size, or the whole does
  // not fit in memory; as a run-time error when a shader does not compile.
  static Expected<GlProgressive> create(const ProgressiveRadiosity& cpu,
                                        const GlProgressiveOptions& gl_options = {});

  GlProgressive(GlProgressive&&) noexcept = default;
  GlProgressive& operator=(GlProgressive&&) noexcept = default;
  GlProgressive(const GlProgressive&) = delete;
  GlProgressive& operator=(const GlProgressive&) = delete;
  ~GlProgressive() = default;

  size_t elementCount() const { return element_count_; }
  uint32_t shooterCount() const { return shooter_count_; }
  // Bytes of textures and buffers this solver holds on the device.
  uint64_t deviceBytes() const { return device_bytes_; }

  // Residual power (luminance, W) of every shooter, from the GPU pass (diagnostics).
  Expected<std::vector<double>> residualPowers();
  // The GPU's shooter selection: the shooter with the highest residual power, kNoShooter when
  // none is left.
  Expected<uint32_t> selectShooter();
  // One iteration with `shooter` (ProgressiveRadiosity's numbering) as the shooter.
  Expected<ProgressiveIteration> shoot(uint32_t shooter);
  // Selects the shooter on the GPU and shoots; iteration 0 when nothing is left.
  Expected<ProgressiveIteration> step();
  // Iterates until the convergence fraction or the iteration cap, counted over the solver's
  // whole life (ProgressiveRadiosity::solve): `after_iteration` after every iteration, `stop`
  // before each (true: return now, between two iterations).
  Expected<ProgressiveStats> solve(
      const std::function<void(const ProgressiveIteration&)>& after_iteration = {},
      const std::function<bool()>& stop = {});

  // The state in ProgressiveRadiosity's element order, and restoring one (element count
  // checked; values must be finite and >= 0).
  Expected<ProgressiveState> download() const;
  Status upload(const ProgressiveState& state);
  int iterations() const { return iterations_; }
  const EnergyBalance& balance() const { return balance_; }
  double unshotFraction() const;

  // Sec. 3.1's post-process: outgoing radiance B / pi per atlas texel (plus rho * ambient / pi
  // with `with_ambient`, eq. 4-6), then unoccupied texels next to filled ones of the same chart
  // filled with their neighbours' mean in gap_fill_passes ping-pong passes, others zero.
  Expected<Image> radianceImage(bool with_ambient = false);

  // Diagnostics of the receiver pass: how many fragments of one receiver pass over every
  // element reach each element's texel (must be exactly 1 everywhere).
  Expected<std::vector<uint32_t>> receiverCoverage();

 private:
  GlProgressive() = default;
  // Steps of create(): the shooters and their points (the CPU's flat substructuring) into
  // `shooters` and `points` and the per-shooter data; the gather with this solver's own buffers
  // and textures in its one size and memory check; the compute passes.
  Status placeShooters(const ProgressiveRadiosity& cpu, std::vector<GpuShooter>& shooters,
                       std::vector<GpuShooterPoint>& points, std::vector<glm::vec4>& polygons,
                       const char* place);
  Status createGather(const ProgressiveRadiosity& cpu, size_t point_count, size_t point_corners,
                      const char* place);
  Status compilePasses();
  // Runs the per-shooter power pass (pass 0).
  void dispatchPower();
  // One receiver pass over the receivers [first, first + count) (or, with `elements`, the
  // elements).
  void drawReceivers(GlHemisphereGather::Pass pass, uint32_t first, uint32_t count,
                     bool elements = false);
  // A shot's points with something to shoot (the CPU drops dB = 0): their indices, their
  // area-weighted mean dB, and where they shoot from, the luminance(dB)-weighted mean of their
  // elements' positions (ProgressiveRadiosity's shooter points).
  struct ActivePoints {
    std::vector<uint32_t> index;
    std::vector<glm::dvec3> residual;
    std::vector<glm::dvec3> position;
  };
  // The batch of shooter points [first, first + count) of `active` (the shooter's points from
  // point_first on) to the gather: uniforms and depth maps.
  void prepareBatch(const ActivePoints& active, uint32_t point_first, uint32_t first,
                    uint32_t count);
  // Sec. 4 before a shooter's first shot (adaptive): the samples pass over every batch, the
  // split on the CPU (ProgressiveReceivers::subdivide) and the new receivers uploaded.
  Status subdivide(uint32_t shooter, const ActivePoints& active, const glm::dvec3& shot,
                   ProgressiveIteration& it);
  // The receivers' buffers (the elements' own when every receiver is one element) and each
  // chart's receivers.
  void uploadReceivers();
  // Coarse receivers wrote their irradiance at one texel each: read back, interpolated to the
  // elements (ProgressiveReceivers::toElements) and written to every element's texel.
  Status spreadIncident();
  // Applies the incident atlas (times `scale`) in the resolve pass, or only sums it; returns
  // the energy sums.
  Expected<GpuResolveSums> resolve(uint32_t shooter, const glm::dvec3& scale, bool apply);
  Status glStatus(const char* what) const;

  ProgressiveOptions options_;
  GlProgressiveOptions gl_options_;
  size_t element_count_ = 0;
  uint32_t shooter_count_ = 0;
  int width_ = 0, height_ = 0;
  uint64_t device_bytes_ = 0;
  double total_area_ = 0.0;
  glm::dvec3 ambient_factor_{1.0};  // R of eq. 6, per channel
  // Per shooter (CPU side): its elements, mean normal (the hemisphere's pole), whether its
  // shots are closed (ProgressiveRadiosity::shotClosed), the points
  // [point_first_[s], point_first_[s + 1]) and its bounding sphere.
  std::vector<glm::uvec2> shooter_elements_;
  std::vector<glm::dvec3> shooter_normal_;
  std::vector<uint8_t> shooter_closed_;
  std::vector<glm::dvec3> shooter_centre_;
  std::vector<double> shooter_radius_;
  std::vector<double> point_max_area_;  // the largest point of each shooter (m^2)
  std::vector<uint32_t> point_first_;
  std::vector<glm::dvec3> point_position_;
  std::vector<double> point_area_;
  std::vector<glm::uvec2> point_members_;  // first element, count
  std::vector<glm::uvec2> point_pieces_;   // first polygon in point_polygons_, count
  // Receivers (sec. 4): the CPU solver's surface (for the hierarchy), the receivers, whether
  // each shooter has subdivided, and each chart's receivers.
  const RadiositySurface* surface_ = nullptr;
  ProgressiveReceivers receivers_;
  std::vector<uint8_t> subdivided_;
  std::vector<glm::uvec2> chart_receivers_;

  EnergyBalance balance_;
  int iterations_ = 0;

  GlHemisphereGather gather_;  // depth maps and receiver passes (Algorithm 1, Fig. 3)
  gl::Program power_, select_, points_, resolve_, radiance_, fill_;
  gl::Buffer element_coverage_;  // per element, its covered share (cut-outs; 1 elsewhere)
  gl::Buffer point_polygons_;    // the points' pieces, 8 corners (vec4) each
  gl::Buffer shooters_, texel_element_, element_area_, points_buf_, point_power_, shooter_power_,
      selection_, sums_, receivers_buf_, receiver_position_d_, samples_;
  gl::Texture radiosity_, residual_;
  std::array<gl::Texture, 2> radiance_maps_;
};

}  // namespace penumbra
