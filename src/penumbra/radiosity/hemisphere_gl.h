// The GPU's hemispherical visibility and gather (Wallner sec. 3, Algorithm 1 and Fig. 3), shared
// by progressive radiosity (progressive_gl.h) and stochastic radiosity (stochastic_gl.h) on the
// GPU: what both do once a shooter is chosen. Built from the chart atlas and hierarchy that the
// CPU solvers use (radiosity/radiosity_surface.h), so that the elements are the CPU's.
//
//  - Depth pass (Algorithm 1): the scene's triangles through each shooter point's hemispherical
//    stereographic projection (around the shooter's normal) into its tile of the depth texture,
//    with the nearest triangle's id; triangles are drawn as k x k sub-triangles (k = ceil(the
//    longest edge in atlas texels / tessellation_texels)), each clipped against the shooter's
//    plane. One texture holds a batch of up to 4 x 4 points.
//  - Receiver pass: every receiver drawn as one point at its texel's centre (exactly one
//    fragment per receiver). The fragment shader back-projects the receiver's point into each
//    batch point's depth map through the sub-triangle the depth pass rasterised and compares
//    depths (Fig. 3, the 3 x 3 neighbourhood only where the texel sees the receiver's own or a
//    touching chart); if visible it adds eq. 2's disc form factor times the point's radiosity,
//    or, for pairs nearer than `near_factor` point sizes, Lambert's exact form factor to each
//    member element's pieces times that element's value in the caller's "sent" atlas (a second
//    pass over the charts that can be that close). The irradiance (W m^-2) adds into the
//    incident atlas by blending.
//    Cut-outs are holes in the depth pass (raytrace/gpu_cutouts.h), so that a receiver behind
//    a lattice sees the shooter through its openings as the CPU's shadow rays do.
//  - Samples pass (sec. 4, optional): per element, whether it faces and sees its paired point.
//
// The callers own what is shot (their residual or sent atlases), the receivers' layout (the
// elements', or coarser receivers in the same layout) and what the incident irradiance becomes.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/gpu/objects.h"
#include "penumbra/radiosity/radiosity_surface.h"
#include "penumbra/raytrace/gpu_cutouts.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace penumbra {

struct GlProgressiveOptions {
  // Each shooter point's depth map's side (texels); one texture holds up to 4 x 4 of them.
  int visibility_resolution = 512;
  // Sub-triangle legs of the depth pass, in atlas texels: k = ceil(longest edge / this), in
  // [1, 64].
  int tessellation_texels = 2;
  float depth_tolerance = 1e-4f;  // relative depth tolerance of the visibility test
  int gap_fill_passes = 2;        // sec. 3.1: two ping-pong passes
  // A smaller maximum texture size than the device's (0: the device's), to test the refusal.
  int max_texture_size = 0;
};

// ---- GPU layouts (std430), mirrored in shaders/radiosity/progressive_layout.glsl ----

struct GpuProgressiveElement {  // 80 bytes
  float position[3];
  float area;
  float reflectance[3];
  uint32_t texel;
  float normal[3];       // unit, its faces' (the side it is on): culling
  uint32_t piece_count;  // its pieces: polygons[8 * piece_first ..], 8 corners each
  float barycentric[2];  // of `position` on `triangle` (for the back projection)
  uint32_t triangle;     // the scene triangle whose face holds its texel's centre
  uint32_t piece_first;
  float shading_normal[3];  // unit: the receiver's cosine (its normal map's, else `normal`)
  uint32_t pad;
};
static_assert(sizeof(GpuProgressiveElement) == 80 &&
              offsetof(GpuProgressiveElement, reflectance) == 16 &&
              offsetof(GpuProgressiveElement, normal) == 32 &&
              offsetof(GpuProgressiveElement, barycentric) == 48 &&
              offsetof(GpuProgressiveElement, piece_first) == 60 &&
              offsetof(GpuProgressiveElement, shading_normal) == 64);

// A scene triangle as an occluder of the depth pass (and the back projection): 48 bytes.
struct GpuProgressiveTriangle {
  float p0[3];
  int32_t front_chart;  // the charts of its front and back faces, -1 for none
  float p1[3];
  uint32_t tessellation;  // the depth pass's sub-triangle grid: k x k sub-triangles
  float p2[3];
  int32_t back_chart;
};
static_assert(sizeof(GpuProgressiveTriangle) == 48 &&
              offsetof(GpuProgressiveTriangle, tessellation) == 28 &&
              offsetof(GpuProgressiveTriangle, p2) == 32);

// One shooter point of a batch, std140 (the uniform block Batch): 96 bytes.
struct GpuBatchPoint {
  double position[4];  // xyz, w = area
  float position_f[4];
  float residual[4];    // its area-weighted mean radiosity to shoot (W m^-2)
  uint32_t members[4];  // first element, count, its index among the shooter's points
  // Where its visibility is taken from, off `position` (cut-outs: radiosity/cutout_jitter.h);
  // set by GlHemisphereGather::prepareBatch.
  float eye[4];
  // Its pieces (its faces clipped to its texels) in the point polygons
  // (PROGRESSIVE_SSBO_POINT_POLYGONS): first, count. Pairs nearer than far_factor of its sizes
  // take Lambert's form factor to them; with none, eq. 2's disc serves every far pair.
  uint32_t pieces[4];
  float pad[4];  // the std140 array stride: a multiple of the dvec4 alignment (32)
};
static_assert(sizeof(GpuBatchPoint) == 128 && offsetof(GpuBatchPoint, position_f) == 32 &&
              offsetof(GpuBatchPoint, residual) == 48 && offsetof(GpuBatchPoint, members) == 64 &&
              offsetof(GpuBatchPoint, eye) == 80 && offsetof(GpuBatchPoint, pieces) == 96);
// Shooter points per receiver pass (MAX_BATCH_POINTS in progressive_layout.glsl): a 4 x 4 grid
// of depth maps in one texture.
inline constexpr int kProgressiveBatchTiles = 4;
// The batch's size for the passes that read it: MAX_BATCH_POINTS, kProgressiveBatchTiles^2 (the
// shaders have no value of their own).
std::vector<std::string> batchPointDefines();

// A buffer a caller of the gather will allocate, for the one memory and size check.
struct GlBufferNeed {
  const char* what;
  uint64_t bytes;
};

class GlHemisphereGather {
 public:
  enum class Pass { kFar, kNear, kSamples };

  // Uploads the occluders, the elements (positions, normals, areas, reflectances, pieces) and
  // the atlas's texel-to-chart map, and compiles the passes (the samples pass with `samples`).
  // `caller_buffers` and `caller_texture_bytes` are what the caller will allocate besides: the
  // device limits (texture size, shader storage block size) and the memory (the machine's on a
  // software rasteriser, the free video memory where the driver says) are checked for the whole
  // before anything is allocated, failing as an input error naming the bytes.
  static Expected<GlHemisphereGather> create(const RadiositySurface& surface,
                                             const GlProgressiveOptions& gl_options,
                                             bool visibility, bool samples, const char* place,
                                             std::span<const GlBufferNeed> caller_buffers,
                                             uint64_t caller_texture_bytes);

  GlHemisphereGather() = default;  // empty: create() makes a usable one
  GlHemisphereGather(GlHemisphereGather&&) noexcept = default;
  GlHemisphereGather& operator=(GlHemisphereGather&&) noexcept = default;
  GlHemisphereGather(const GlHemisphereGather&) = delete;
  GlHemisphereGather& operator=(const GlHemisphereGather&) = delete;
  ~GlHemisphereGather() = default;

  // Bytes of textures and buffers on the device, the caller's included.
  uint64_t deviceBytes() const { return device_bytes_; }
  // Points per batch (tiles^2, at most 16).
  uint32_t batchSize() const { return tiles_ * tiles_; }
  int width() const { return width_; }
  int height() const { return height_; }
  size_t elementCount() const { return element_texel_.size(); }
  uint32_t elementTexel(size_t e) const { return element_texel_[e]; }
  const std::vector<uint32_t>& elementTexels() const { return element_texel_; }
  // Per chart: its elements [x, x + y).
  const std::vector<glm::uvec2>& chartElements() const { return chart_elements_; }
  // The elements (GpuProgressiveElement) and the texel-to-chart map, for the callers' passes.
  const gl::Buffer& elements() const { return elements_; }
  const gl::Buffer& texelChart() const { return texel_chart_; }
  // The incident irradiance atlas (RGBA32F) the receiver passes add into.
  const gl::Texture& incident() const { return incident_; }

  // The shooter's hemisphere (its pole, unit) and, for the next batches, the factors of the
  // near pairs (d^2 < near^2 A, the near pass) and of the pairs that take Lambert's form factor
  // to the point's pieces in the far pass (d^2 < far^2 A, when the point has pieces). Pairs with
  // d^2 < local^2 A are left out of both (stochastic radiosity's local operator takes them).
  void setShooter(const glm::dvec3& normal, double near_factor, double far_factor,
                  double local_factor = 0.0);
  // The samples pass's pairing: element e with the shooter's point e mod `points`.
  void setSamplePoints(uint32_t points);
  void clearIncident();
  // The batch's points as the passes' uniforms, and their depth maps (Algorithm 1). With
  // cut-outs, each point's visibility is taken from a spot of its disc (its `eye`, set here).
  void prepareBatch(std::span<const GpuBatchPoint> points);
  // Charts that can hold near pairs (d^2 < near^2 A) with a shooter in the sphere (centre,
  // radius) whose largest point has area `max_point_area`: their ranges in `ranges` (per chart,
  // first and count; empty ones skipped).
  std::vector<glm::uvec2> nearCharts(const glm::dvec3& centre, double radius, double max_point_area,
                                     double near_factor,
                                     const std::vector<glm::uvec2>& ranges) const;

  // The receivers a pass draws: the elements' own buffers, or the caller's coarser receivers
  // (GpuProgressiveElement) with their points in double.
  struct Receivers {
    const gl::Buffer* receivers = nullptr;  // null: the elements
    const gl::Buffer* positions = nullptr;
  };
  // One pass over the receivers [first, first + count) against the prepared batch; `sent` is the
  // atlas the near pass reads the members' values from; `samples` the samples pass's output
  // (4 bytes per element).
  void draw(Pass pass, uint32_t first, uint32_t count, const Receivers& receivers, GLuint sent,
            const gl::Buffer* samples = nullptr);
  // Diagnostics: fragments of one receiver pass over every element per element (must be 1);
  // `sent` any RGBA32F atlas other than the incident one.
  Expected<std::vector<uint32_t>> coverage(GLuint sent);

 private:
  // Steps of create(): each chart's elements and bounding sphere; the incident atlas, the depth
  // maps and their framebuffers.
  void placeCharts(const ChartAtlas& atlas, const SurfaceHierarchy& hierarchy);
  Status createTargets(int d, const char* place);

  int width_ = 0, height_ = 0;
  uint64_t device_bytes_ = 0;
  float far_ = 1.0f;
  glm::dvec3 shooter_normal_{0.0, 0.0, 1.0};
  uint64_t batches_ = 0;  // batches prepared (the cut-out jitter's key)
  bool visibility_ = true;
  float depth_tolerance_ = 1e-4f;
  int visibility_resolution_ = 512;
  uint32_t tiles_ = 1;
  uint32_t sub_triangle_count_ = 0;
  std::vector<uint32_t> element_texel_;
  // Per chart: its elements and bounding sphere (the near pass draws the charts in reach).
  std::vector<glm::uvec2> chart_elements_;
  std::vector<glm::dvec3> chart_centre_;
  std::vector<double> chart_radius_;

  gl::Program depth_, receive_far_, receive_near_, sample_;
  gl::Buffer triangles_, elements_, element_position_d_, texel_chart_, sub_triangles_, polygons_,
      chart_adjacency_first_, chart_adjacency_, batch_;
  gl::Texture incident_, depth_map_, id_map_;
  gl::Framebuffer atlas_fbo_, depth_fbo_;
  gl::VertexArray vao_;
  std::optional<GlCutouts> cutouts_;  // the depth pass's holes, when the scene has cut-outs
};

}  // namespace penumbra
