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
#include "penumbra/raytrace/ray.h"

#include <glm/vec3.hpp>

#include <span>
#include <vector>

namespace penumbra {

class GlRayEngine {
 public:
  // Builds the canonical BVH and uploads it with the triangles in leaf order. Fails (as a
  // value) when the shader does not compile or the buffers exceed the device's limits.
  static Expected<GlRayEngine> build(std::span<const glm::vec3> positions,
                                     std::span<const glm::uvec3> triangles,
                                     const BvhBuildOptions& options = {});

  // Closest hits in input order.
  Status intersect(const RayBatch& rays, HitBatch& hits) const;
  // Occlusion answers in input order.
  Status occluded(const RayBatch& rays, std::vector<uint8_t>& occluded) const;

  size_t triangleCount() const { return triangle_count_; }

 private:
  Status run(const RayBatch& rays, bool any_hit, std::vector<struct GpuHit>& out) const;

  gl::Program program_;
  gl::Buffer nodes_, triangles_;
  size_t triangle_count_ = 0;
  int64_t max_ssbo_bytes_ = 0;
};

}  // namespace penumbra
