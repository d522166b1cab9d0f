#include "viewer/orbit_camera.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>

namespace penumbra::viewer {

namespace {

constexpr float kPi = 3.14159265358979f;
constexpr float kMaxPitch = 0.4995f * kPi;

}  // namespace

// The eye's direction from the target in the frame whose vertical is `up_` (y up: yaw about y,
// pitch above the horizon).
glm::vec3 OrbitCamera::eyeDirection() const {
  const glm::vec3 local(std::cos(pitch_) * std::sin(yaw_), std::sin(pitch_),
                        std::cos(pitch_) * std::cos(yaw_));
  // A frame with up_ as its y axis.
  const glm::vec3 y = up_;
  const glm::vec3 helper = std::abs(y.z) < 0.9f ? glm::vec3(0, 0, 1) : glm::vec3(1, 0, 0);
  const glm::vec3 x = glm::normalize(glm::cross(y, helper));
  const glm::vec3 z = glm::cross(x, y);
  return local.x * x + local.y * y + local.z * z;
}

void OrbitCamera::set(const Camera& camera) {
  up_ = glm::length(camera.up) > 0.0f ? glm::normalize(camera.up) : glm::vec3(0, 1, 0);
  target_ = camera.look_at;
  fov_ = camera.vertical_fov;
  glm::vec3 d = camera.position - camera.look_at;
  distance_ = std::max(glm::length(d), 1e-6f);
  d /= distance_;
  const glm::vec3 y = up_;
  const glm::vec3 helper = std::abs(y.z) < 0.9f ? glm::vec3(0, 0, 1) : glm::vec3(1, 0, 0);
  const glm::vec3 x = glm::normalize(glm::cross(y, helper));
  const glm::vec3 z = glm::cross(x, y);
  pitch_ = std::asin(std::clamp(glm::dot(d, y), -1.0f, 1.0f));
  yaw_ = std::atan2(glm::dot(d, x), glm::dot(d, z));
}

Camera OrbitCamera::camera() const {
  Camera c;
  c.look_at = target_;
  c.position = target_ + eyeDirection() * distance_;
  c.up = up_;
  c.vertical_fov = fov_;
  return c;
}

void OrbitCamera::orbit(const glm::vec2& delta, float height) {
  const float turn = kPi / std::max(height, 1.0f);
  yaw_ -= delta.x * turn;
  pitch_ = std::clamp(pitch_ + delta.y * turn, -kMaxPitch, kMaxPitch);
}

void OrbitCamera::pan(const glm::vec2& delta, float height) {
  const Camera c = camera();
  const glm::vec3 forward = glm::normalize(c.look_at - c.position);
  const glm::vec3 right = glm::normalize(glm::cross(forward, up_));
  const glm::vec3 up = glm::cross(right, forward);
  // The view's height at the target's distance.
  const float span = 2.0f * distance_ * std::tan(0.5f * fov_);
  const float scale = span / std::max(height, 1.0f);
  target_ += (-delta.x * right + delta.y * up) * scale;
}

void OrbitCamera::look(const glm::vec2& delta, float height) {
  // The eye stays; the target turns about it.
  const glm::vec3 eye = camera().position;
  orbit(-delta, height);
  // Turning about the eye turns the other way from orbiting about the target.
  target_ = eye - eyeDirection() * distance_;
}

void OrbitCamera::dolly(float steps) {
  distance_ = std::max(distance_ * std::pow(0.85f, steps), 1e-4f);
}

void OrbitCamera::fly(const glm::vec3& right_up_forward, float scale) {
  const Camera c = camera();
  const glm::vec3 forward = glm::normalize(c.look_at - c.position);
  const glm::vec3 right = glm::normalize(glm::cross(forward, up_));
  const glm::vec3 up = glm::cross(right, forward);
  target_ +=
      (right_up_forward.x * right + right_up_forward.y * up + right_up_forward.z * forward) * scale;
}

}  // namespace penumbra::viewer
