// Primary rays of a pinhole camera.
#pragma once

#include "penumbra/core/sobol.h"
#include "penumbra/kernels/ray.h"
#include "penumbra/scene/camera.h"

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>

#include <cmath>
#include <optional>

namespace penumbra {

// Maps image-plane positions to rays. Pixel (x, y) covers [x, x+1) x [y, y+1); y = 0 is the top
// row; the image is centred on the view direction.
class CameraRays {
 public:
  CameraRays(const Camera& cam, int width, int height) : origin_(cam.position) {
    forward_ = glm::normalize(cam.look_at - cam.position);
    right_ = glm::normalize(glm::cross(forward_, cam.up));
    up_ = glm::cross(right_, forward_);
    const float tan_half = std::tan(0.5f * cam.vertical_fov);
    scale_y_ = tan_half;
    scale_x_ = tan_half * float(width) / float(height);
    inv_w_ = 1.0f / float(width);
    inv_h_ = 1.0f / float(height);
  }

  // The inverse of ray(): where point p appears, in pixel units, and its depth along the view
  // direction; nothing for points at or behind the eye.
  std::optional<glm::vec2> project(const glm::vec3& p, float* depth = nullptr) const {
    const glm::vec3 d = p - origin_;
    const float z = glm::dot(d, forward_);
    if (!(z > 0.0f)) return std::nullopt;
    if (depth) *depth = z;
    const float sx = glm::dot(d, right_) / z / scale_x_, sy = glm::dot(d, up_) / z / scale_y_;
    return glm::vec2(0.5f * (sx + 1.0f) / inv_w_, 0.5f * (1.0f - sy) / inv_h_);
  }
  // The point at depth `depth` along the view direction that appears at (px, py).
  glm::vec3 unproject(float px, float py, float depth) const {
    const float sx = (2.0f * px * inv_w_ - 1.0f) * scale_x_;
    const float sy = (1.0f - 2.0f * py * inv_h_) * scale_y_;
    return origin_ + depth * (forward_ + sx * right_ + sy * up_);
  }

  // (px, py) in pixel units, e.g. x + 0.5 for the pixel centre. The direction is unit length.
  Ray ray(float px, float py) const {
    const float sx = (2.0f * px * inv_w_ - 1.0f) * scale_x_;
    const float sy = (1.0f - 2.0f * py * inv_h_) * scale_y_;
    Ray r;
    r.origin = origin_;
    r.dir = glm::normalize(forward_ + sx * right_ + sy * up_);
    return r;
  }

 private:
  glm::vec3 origin_, forward_, right_, up_;
  float scale_x_, scale_y_, inv_w_, inv_h_;
};

// The key of pixel `pixel`'s Sobol patterns (core/sobol.h: sobolPattern) for a render seeded
// `seed`; pattern 0 places its samples in the pixel. The path tracer's paths and every other
// method's view rays (pixelJitter) take their pixel positions from it.
inline uint64_t pixelPatternKey(uint64_t seed, uint64_t pixel) {
  return mixBits(mixBits(seed) ^ pixel);
}

// Where sample `s` of a pixel's `spp` samples falls in the pixel, in [0, 1)^2: the pixel's centre
// for one sample, else the path tracer's own position for it (point s of the pixel's pattern 0),
// so that the first 2^m samples are one per elementary interval of area 2^-m and a pixel's
// samples cover it evenly (stratified; each point on its own is uniform, as independent jitter
// is). At the 4 samples per pixel the view rays default to, the pixels along an emitter's edge
// vary far less than with independent jitter.
inline glm::vec2 pixelJitter(uint64_t seed, uint64_t pixel, uint32_t s, int spp) {
  if (spp == 1) return glm::vec2(0.5f);
  const SobolPoint p = owenSobol2D(s, sobolPattern(pixelPatternKey(seed, pixel), 0));
  return glm::vec2(p.u, p.v);
}

}  // namespace penumbra
