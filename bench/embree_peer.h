// Embree 3, the Ray Engine's benchmark peer (design doc sec. 7): a scene of the same triangles
// built at RTC_BUILD_QUALITY_HIGH, and batches traced on all threads through Embree's single-ray
// and 8-ray packet entry points, closest hit or occlusion, converting from Penumbra's ray layout
// inside the call (as a caller of either library would).
#pragma once

#include "penumbra/kernels/ray.h"

#include <embree3/rtcore.h>
#include <glm/vec3.hpp>

#include <cstdint>
#include <span>
#include <vector>

namespace penumbra::bench {

class EmbreePeer {
 public:
  // Builds on `device` when given (the caller keeps it), else on a device of its own whose
  // memory monitor counts what the scene holds beyond the vertex and index buffers.
  EmbreePeer(std::span<const glm::vec3> positions, std::span<const glm::uvec3> triangles,
             RTCDevice device = nullptr);
  ~EmbreePeer();
  EmbreePeer(const EmbreePeer&) = delete;
  EmbreePeer& operator=(const EmbreePeer&) = delete;

  RTCDevice device() const { return device_; }
  // Bytes of Embree's BVH and leaf data (own device only; 0 otherwise).
  int64_t bytes() const { return bytes_; }

  // `hits` and `occluded` must already have rays.size() elements.
  void intersect1(const RayBatch& rays, HitBatch& hits) const;
  void intersect8(const RayBatch& rays, HitBatch& hits) const;
  void occluded1(const RayBatch& rays, std::vector<uint8_t>& occluded) const;
  void occluded8(const RayBatch& rays, std::vector<uint8_t>& occluded) const;

 private:
  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
  bool own_device_ = false;
  int64_t bytes_ = 0;
};

}  // namespace penumbra::bench
