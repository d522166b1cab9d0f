// The Ray Engine's GPU back end (OpenGL 4.5 compute): the general kernel, one invocation per
// ray traversing the canonical binary BVH (shaders/raytrace/bvh_intersect.comp). Returns
// exactly what the CPU back end returns: the same triangle except at true ties, t within 1e-5
// relative (tests/raytrace/ray_engine_gl_test.cpp).
//
// Needs a current OpenGL context (gpu/context.h) on the calling thread.
#pragma once

#include "penumbra/accel/bvh.h"
#include "penumbra/core/expected.h"
#include "penumbra/gpu/objects.h"
#include "penumbra/kernels/bucket_cull.h"
#include "penumbra/kernels/ray.h"
#include "penumbra/raytrace/gpu_cutouts.h"

#include <glm/vec3.hpp>

#include <optional>
#include <span>
#include <string>
#include <vector>

namespace penumbra {

// The #defines shaders/raytrace/bvh_intersect.comp is compiled with: the traversal stack
// (accel/bvh.h kMaxBvhDepth) and the work-group size the dispatch assumes.
std::vector<std::string> bvhIntersectDefines();

class GlRayEngine {
 public:
  // Builds the canonical BVH and uploads it with the triangles in leaf order. Fails (as a
  // value) when the shader does not compile or the buffers exceed the device's limits. With
  // `cutouts` (the triangles' textures, when some have cut-outs), rays pass through holes as
  // the CPU's hit filter lets them (raytrace/gpu_cutouts.h); without, the kernel has no test.
  static Expected<GlRayEngine> build(std::span<const glm::vec3> positions,
                                     std::span<const glm::uvec3> triangles,
                                     const BvhBuildOptions& options = {},
                                     const SurfaceTextures* cutouts = nullptr);

  // Closest hits in input order.
  Status intersect(const RayBatch& rays, HitBatch& hits) const;
  // Occlusion answers in input order.
  Status occluded(const RayBatch& rays, std::vector<uint8_t>& occluded) const;
  // Rays already on the device (`count` GpuRay in `rays`), answers left there (GpuHit in
  // `hits`; any_hit: the first hit found, triangle >= 0 when occluded), for passes that make
  // and use their rays on the GPU. A ray with tmin > tmax is skipped (no hit). Fails when
  // `count` exceeds one dispatch (65535 x 64 rays) or the device's buffer limit.
  Status traceResident(const gl::Buffer& rays, const gl::Buffer& hits, size_t count,
                       bool any_hit) const;

  size_t triangleCount() const { return triangle_count_; }

 private:
  Status run(const RayBatch& rays, bool any_hit, std::vector<struct GpuHit>& out) const;

  gl::Program program_;
  gl::Buffer nodes_, triangles_;
  std::optional<GlCutouts> cutouts_;
  size_t triangle_count_ = 0;
  int64_t max_ssbo_bytes_ = 0;
};

// The Ray Engine paper's own GPU kernel (Carr et al. 2002, sec. 3.3-4.3): rays held per pixel in
// a ray-origins and a ray-directions texture, every triangle broadcast as a screen-filling quad,
// eq. 1-8 in the fragment shader, the nearest hit kept by the depth test (the t-buffer) and the
// triangle id in a colour target (shaders/raytrace/raster_intersect.*). It tests every ray of a
// tile against every triangle it is given: the kernel for a coherent bucket of rays against
// the small set of triangles of a GPU cell (sec. 5.3, 6.2), not for whole scenes. The vertex
// stage culls the triangles that no ray of the pass can reach (sec. 5.3, kernels/bucket_cull.h):
// the quad is moved off screen and clipped; answers are the same as without culling.
class GlRasterKernel {
 public:
  // Uploads the triangles. Slot i holds triangle order[i] (id order[i]), or triangle i when
  // `order` is empty; a BVH's leaf order makes every subtree a contiguous range of slots.
  // `tile` x `tile` rays are traced per pass.
  static Expected<GlRasterKernel> create(std::span<const glm::vec3> positions,
                                         std::span<const glm::uvec3> triangles, int tile = 64,
                                         std::span<const uint32_t> order = {});

  // Closest hits of `rays` among slots [first, first + count) in input order (all by default).
  // Exact ties go to the lower slot (drawn first; the depth test is GL_LESS).
  Status intersect(const RayBatch& rays, HitBatch& hits, uint32_t first = 0,
                   uint32_t count = ~0u) const;

  // Asynchronous use (sec. 5.1: the CPU keeps working while the GPU intersects): submit() sends
  // up to tile x tile rays (rays[ray_indices[k]]) against slots [first, first + count) and
  // starts reading the results back into buffers behind a fence; collect() waits for the fence
  // if needed and writes the k-th ray's hit to out[k]. `bound` is the bucket's culling bound,
  // computed from the rays as uploaded.
  struct Job {
    gl::Buffer ids, tuv;
    gl::Fence fence;
    size_t rays = 0;
    RayBucketBound bound;
  };
  Expected<Job> submit(const RayBatch& rays, std::span<const uint32_t> ray_indices, uint32_t first,
                       uint32_t count) const;
  static bool ready(const Job& job) { return job.fence.ready(); }
  void collect(Job& job, Hit* out) const;

  int tile() const { return tile_; }
  uint32_t slotCount() const { return triangle_count_; }

  // How many of slots [first, first + count) the vertex stage culls for a pass with `bound`:
  // the C++ twin of the shader's test on the same triangle boxes (for statistics; O(count)).
  size_t culledTriangles(const RayBucketBound& bound, uint32_t first, uint32_t count) const;

 private:
  gl::Program program_;
  gl::Buffer triangles_;
  gl::Texture origins_, directions_, id_target_, tuv_target_;
  gl::Renderbuffer depth_;
  gl::Framebuffer framebuffer_;
  gl::VertexArray vao_;
  uint32_t triangle_count_ = 0;
  int tile_ = 64;
  glm::vec3 box_lo_{0.0f}, box_hi_{0.0f};
  std::vector<glm::vec3> slot_lo_, slot_hi_;  // each slot's triangle's bounding box
};

// Sets the uniform struct `bucket` (shaders/common/bucket_cull.glsl) of the current program.
void setBucketBoundUniforms(GLuint program, const RayBucketBound& bound);

}  // namespace penumbra
