// Progressive refinement radiosity on the GPU (OpenGL 4.5), Wallner sec. 3 and 3.1: the twin of
// the CPU solver ProgressiveRadiosity (progressive.h), built from one and working on the same
// lightmap atlas and the same elements (the kInside texels, with the CPU's exact-coverage
// centroids, areas and reflectances uploaded per element), so that the two can hand the state
// back and forth (download() / upload(), ProgressiveRadiosity::state() / setState()). It runs
// the CPU's flat substructuring (ProgressiveOptions::shooter_level; shooter_top_points, the
// CPU's hierarchical refinement, is not used here) with each triangle's own normal
// (ProgressiveOptions::shading_normals is not used here either).
//
//  - Textures (sec. 3): the radiosity B and residual dB atlases, RGBA32F of the atlas's size,
//    alpha = 1 on occupied (kInside) texels; an "incident" RGBA32F target that gathers an
//    iteration's irradiance; a stencil buffer of the atlas's size (below); one depth texture
//    holding the depth maps of a batch of up to 4 x 4 shooter points (DEPTH_COMPONENT32F,
//    visibility_resolution^2 per point). Per element, from the CPU: point (float, and double for
//    the near-pair test), area, reflectance, texel, and the polygon of the texels along the
//    chart's edges (for the exact near-pair form factor).
//  - Shooter selection (sec. 3) on the GPU: the residual power of every triangle, the sum over
//    its occupied texels of luminance(dB) (0.3 R + 0.59 G + 0.11 B) times the element area (the
//    paper averages only alpha = 1 texels by a mipmap ping-pong over one texture per triangle;
//    our charts share one atlas, so a compute pass sums each triangle's own elements), then a
//    max reduction in one work group; only the winner (16 bytes) is read back. Sums are in
//    double and in the CPU's element order, ties go to the lowest index as in the CPU's scan, so
//    the two pick the same triangle unless two powers agree to within the float rounding of the
//    GPU's dB (about 1e-7 relative): then either may win. In the furnace, where all 12
//    triangles start with equal power, the CPU's rounding picks triangle 1 first and the GPU
//    triangle 0 (every later pick of 24 agrees); on the Cornell box the first 40 shooters are
//    identical (ProgressiveGl.SelectsTheSameShootersAsTheCpu).
//  - Shooting, per batch of shooter points (the CPU's points: elements, or 2^level x 2^level
//    blocks of atlas texels with summed area and area-weighted mean position and dB; membership
//    and positions from the CPU, the dB sums by a compute pass, read back for the books):
//     1. depth pass (Algorithm 1): the scene through each point's hemispherical stereographic
//        projection into its tile of the depth texture (one instance per point), the linear
//        depth distance / far computed in the vertex shader. Triangles are drawn as k x k
//        sub-triangles (k = ceil(leg / tessellation_texels)), each clipped against the
//        shooter's plane (the part behind is culled; coplanar geometry counts as behind);
//     2. receiver pass: every receiver triangle (not wholly behind the shooter's plane and
//        facing it, the CPU's test) rendered orthographically into the atlas through its
//        lightmap UVs, as polygon, outline (line width 1, sec. 3.1) and corner points. The
//        fragment shader back-projects its element's point into each point's depth map through
//        the same clipped sub-triangle the depth pass rasterised (the paper's "same error"),
//        compares depths at the texel and its 8 neighbours (Fig. 3) and, if visible, adds
//        eq. 2's disc form factor times the point's dB; pairs closer than kProgressiveNear
//        shooter element sizes get Lambert's exact form factor to each member element's
//        polygon instead (as the CPU does), in a second pass drawn only for the receivers
//        whose bounding spheres come that close. The sum goes into the incident target by
//        additive blending.
//    Double counting is impossible: a fragment only writes into a kInside texel of its own
//    triangle, and a stencil test (NOTEQUAL stamp, REPLACE), done before shading, lets exactly
//    one fragment per texel through in each receiver pass; every fragment of a texel would
//    compute the same value from per-texel data, so which one gets through does not matter
//    (ProgressiveGl.ReceiverPassCoversEveryTexelOnce: without the guard 21% of the elements
//    are reached twice). After all points a compute pass applies B += rho E_in,
//    dB += rho E_in, zeroes the shooter's dB, and reduces E_in * area per work group in double.
//  - Energy books (W per channel) exactly as the CPU keeps them: emitted; absorbed =
//    sum (1 - rho) E_in A; unshot = emitted - shot + reflected (running); escaped = shot -
//    arrived. emitted = absorbed + unshot + escaped holds after every iteration, with the unshot
//    power recomputed from the GPU's float dB, to 3e-8 relative.
//  - Post-process (sec. 3.1): radianceImage() writes B / pi per occupied texel, the border row
//    past each chart's hypotenuse from the plane through the three texels before it (the CPU's
//    radianceImage rule, no seam along a quad's diagonal; border_plane = false fills it like
//    every other gap, the paper's way), then in `gap_fill_passes` ping-pong passes (2, the
//    paper's) gives every unoccupied texel next to filled texels of the same triangle their
//    mean, so bilinear lookups inside a chart never read unlit texels. Its kInside and kBorder
//    texels agree with the CPU's radianceImage of the same state to 3e-6.
//
// Agreement with the CPU on the same atlas, measured on llvmpipe
// (tests/radiosity/progressive_gl_test.cpp), both driven by the CPU's shooter sequence:
//  - furnace (6 texels/m, 1092 elements, no occluders), 24 iterations: per-element relative
//    RMS 3.3e-7, max 9.6e-7; one shot: gains within 6.5e-6. Converged on the GPU: every element
//    within 0.73% of E / (1 - rho) (ProgressiveGl.MatchesTheCpuInTheFurnace,
//    FurnaceConvergesToTheClosedFormWithBalancedBooks).
//  - Cornell box (25 texels/m, 1684 elements, shooter_level 1), 30 iterations, 512^2 depth
//    maps, sub-triangles of 4 texels: relative RMS 5.0e-3; the largest difference 0.41 of the
//    mean radiosity, on texels the CPU's rays find closed (the ceiling 0.8 mm above the light,
//    the floor at the edge of a box's base) and the 3 x 3 depth test of Fig. 3 opens; 12% of
//    the elements differ by more than 5%, along shadow boundaries
//    (ProgressiveGl.MatchesTheCpuOnTheCornellBox). Testing the centre texel only (no Fig. 3
//    neighbourhood) gives RMS 4.2e-2: false occlusion of surfaces seen at grazing angles.
//
// The shaders avoid variable-length arrays and put work behind loops rather than branches where
// a SIMD rasteriser would otherwise run both sides (llvmpipe, which the tests run on, does).
//
// Limitations: no occlusion queries (sec. 3 uses them to skip receivers that see nothing of the
// shooter; every receiver facing it is drawn, with the same result); the iteration's `rays` is
// 0 (no rays are traced); needs a current OpenGL 4.5 context on the calling thread.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/gpu/objects.h"
#include "penumbra/radiosity/progressive.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

namespace penumbra {

struct GlProgressiveOptions {
  // Each shooter point's depth map's side (texels); one texture holds up to 4 x 4 of them.
  int visibility_resolution = 512;
  // Sub-triangle legs of the depth pass, in atlas texels: k = ceil(leg / this), in [1, 64].
  int tessellation_texels = 4;
  float depth_tolerance = 1e-4f;  // relative depth tolerance of the visibility test
  int gap_fill_passes = 2;        // sec. 3.1: two ping-pong passes
  // The border row past each chart's hypotenuse from the plane through the three inside texels
  // before it (the CPU's radianceImage, no seams along a quad's diagonal); false: from the
  // neighbours' mean like every other gap (the paper's sec. 3.1).
  bool border_plane = true;
  // A smaller maximum texture size than the device's (0: the device's), to test the refusal.
  int max_texture_size = 0;
};

// ---- GPU layouts (std430), mirrored in shaders/radiosity/progressive_layout.glsl ----

struct GpuProgressiveElement {  // 48 bytes
  float position[3];
  float area;
  float reflectance[3];
  uint32_t texel;
  float barycentric[2];
  uint32_t triangle;
  uint32_t polygon;  // index of its polygon (8 x vec4) when not a whole texel square, else ~0
};
static_assert(sizeof(GpuProgressiveElement) == 48 &&
              offsetof(GpuProgressiveElement, reflectance) == 16 &&
              offsetof(GpuProgressiveElement, barycentric) == 32 &&
              offsetof(GpuProgressiveElement, polygon) == 44);

struct GpuProgressiveTriangle {  // 112 bytes
  float p0[3];
  float area;
  float p1[3];
  int32_t leg;
  float p2[3];
  uint32_t right;
  float normal[3];
  uint32_t tessellation;
  float uv[3][2];
  uint32_t element_first;
  uint32_t element_count;
  int32_t corner[2];  // the chart (lightmap_atlas.h)
  int32_t axis[2];
};
static_assert(sizeof(GpuProgressiveTriangle) == 112 &&
              offsetof(GpuProgressiveTriangle, axis) == 104 &&
              offsetof(GpuProgressiveTriangle, leg) == 28 &&
              offsetof(GpuProgressiveTriangle, normal) == 48 &&
              offsetof(GpuProgressiveTriangle, uv) == 64 &&
              offsetof(GpuProgressiveTriangle, element_first) == 88);

// A shooter point's elements, members[member_first, + member_count): 8 bytes.
struct GpuShooterPoint {
  uint32_t member_first;
  uint32_t member_count;
};
static_assert(sizeof(GpuShooterPoint) == 8);

// One shooter point of a batch, std140 (the uniform block Batch): 96 bytes.
struct GpuBatchPoint {
  double position[4];  // xyz, w = area
  float position_f[4];
  float residual[4];
  uint32_t members[4];  // first, count
  uint32_t pad[4];      // std140 array stride: a multiple of the dvec4 alignment (32)
};
static_assert(sizeof(GpuBatchPoint) == 96 && offsetof(GpuBatchPoint, position_f) == 32 &&
              offsetof(GpuBatchPoint, residual) == 48 && offsetof(GpuBatchPoint, members) == 64);
// Shooter points per receiver pass (MAX_BATCH_POINTS in progressive_layout.glsl): a 4 x 4 grid
// of depth maps in one texture.
inline constexpr int kProgressiveBatchTiles = 4;

struct GpuSelection {  // 16 bytes
  double power;
  uint32_t triangle;
  uint32_t pad;
};
static_assert(sizeof(GpuSelection) == 16 && offsetof(GpuSelection, triangle) == 8);

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
  // iterations), and takes its options (shooter_level, visibility, convergence,
  // max_iterations). Fails, as an input error naming the bytes, before allocating
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
  uint32_t triangleCount() const { return triangle_count_; }
  // Bytes of textures and buffers this solver holds on the device.
  uint64_t deviceBytes() const { return device_bytes_; }

  // Residual power (luminance, W) of every triangle, from the GPU pass (diagnostics).
  Expected<std::vector<double>> residualPowers();
  // The GPU's shooter selection: the triangle with the highest residual power, kNoShooter
  // when none is left.
  Expected<uint32_t> selectShooter();
  // One iteration with triangle `shooter` as the shooter.
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
  // with `with_ambient`, eq. 4-6), the border rows from the charts' planes (border_plane), then
  // unoccupied texels next to filled ones of the same triangle filled with their neighbours'
  // mean in gap_fill_passes ping-pong passes, others zero.
  Expected<Image> radianceImage(bool with_ambient = false);

  // Diagnostics of the receiver pass: how many fragments of one receiver pass (every
  // non-degenerate triangle: polygons, outlines, corner points) reach each element, with the
  // stencil guard (`guarded`; must be exactly 1 everywhere) or without it (texels on the edges
  // are then reached 2 or 3 times).
  Expected<std::vector<uint32_t>> receiverCoverage(bool guarded);

 private:
  GlProgressive() = default;
  // Runs the per-triangle power pass (pass 0).
  void dispatchPower();
  // Receivers of `shooter` (the CPU's plane tests, in double) into receivers_ on the GPU: all
  // of them, then those that can hold near pairs; returns the two counts.
  glm::uvec2 uploadReceivers(uint32_t shooter);
  // One receiver pass of `program` over receivers_[first, first + count): polygons, outlines
  // and corner points, with the stencil guard when `guarded`.
  void drawReceivers(const gl::Program& program, uint32_t first, uint32_t count, bool guarded);
  void nextStamp();
  Status glStatus(const char* what) const;

  ProgressiveOptions options_;
  GlProgressiveOptions gl_options_;
  size_t element_count_ = 0;
  uint32_t triangle_count_ = 0;
  int width_ = 0, height_ = 0;
  uint64_t device_bytes_ = 0;
  float far_ = 1.0f;
  double total_area_ = 0.0;
  glm::dvec3 ambient_factor_{1.0};  // R of eq. 6, per channel
  // Per triangle (CPU side): corners, unit normals, areas (double, as the CPU computes them),
  // and the shooter points [point_first_[t], point_first_[t + 1]).
  std::vector<std::array<glm::dvec3, 3>> corners_;
  std::vector<glm::dvec3> normals_;
  std::vector<double> areas_;
  std::vector<glm::dvec3> sphere_centre_;  // bounding spheres (centroid, farthest corner)
  std::vector<double> sphere_radius_;
  std::vector<double> point_max_area_;  // the largest shooter point of each triangle (m^2)
  std::vector<uint32_t> point_first_;
  std::vector<glm::dvec3> point_position_;
  std::vector<double> point_area_;
  std::vector<glm::uvec2> point_members_;  // first, count in members_
  std::vector<uint32_t> element_texel_;
  uint32_t sub_triangle_count_ = 0;

  EnergyBalance balance_;
  int iterations_ = 0;
  int stamp_ = 0;       // the stencil value of the current receiver pass (1..255)
  uint32_t tiles_ = 1;  // a batch of tiles^2 shooter points shares the depth texture

  gl::Program power_, select_, points_, resolve_, radiance_, fill_, depth_, receive_far_,
      receive_near_;
  gl::Buffer triangles_, elements_, texel_element_, texel_triangle_, element_area_, points_buf_,
      point_power_, members_, sub_triangles_, receivers_, triangle_power_, selection_, sums_,
      element_position_d_, batch_, polygons_;
  gl::Texture radiosity_, residual_, incident_, depth_map_;
  std::array<gl::Texture, 2> radiance_maps_;
  gl::Renderbuffer stencil_;
  gl::Framebuffer atlas_fbo_, depth_fbo_;
  gl::VertexArray vao_;
};

}  // namespace penumbra
