// Embree 3 as a test oracle and benchmark peer: the same triangles, closest hits per ray.
#pragma once

#include "penumbra/kernels/ray.h"

#include <glm/vec3.hpp>

#include <span>

struct RTCDeviceTy;
struct RTCSceneTy;

namespace penumbra::test {

class EmbreeScene {
 public:
  EmbreeScene(std::span<const glm::vec3> positions, std::span<const glm::uvec3> triangles,
              bool robust = true);
  ~EmbreeScene();
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  Hit intersect(const Ray& ray) const;
  RTCSceneTy* scene() const { return scene_; }

 private:
  RTCDeviceTy* device_ = nullptr;
  RTCSceneTy* scene_ = nullptr;
};

}  // namespace penumbra::test
