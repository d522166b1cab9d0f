#include "viewer/orbit_camera.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>

namespace penumbra::viewer {

namespace {

constexpr float kPi = 3.14159265358979f;
constexpr float kMaxPitch = 0.4995f * kPi;

// A frame whose y axis is the camera's up: yaw turns about it, pitch rises above its horizon.
struct UpFrame {
  glm::vec3 x, y, z;
  explicit UpFrame(const glm::vec3& up) : y(glm::normalize(up)) {
    const glm::vec3 helper = std::abs(y.z) < 0.9f ? glm::vec3(0, 0, 1) : glm::vec3(1, 0, 0);
    x = glm::normalize(glm::cross(y, helper));
    z = glm::cross(x, y);
  }
};

// The view's right, up and forward axes.
void viewAxes(const Camera& c, glm::vec3& right, glm::vec3& up, glm::vec3& forward) {
  forward = glm::normalize(c.look_at - c.position);
  right = glm::normalize(glm::cross(forward, c.up));
  up = glm::cross(right, forward);
}

// `from` turned about `pivot` by the mouse: yaw about the up axis, pitch kept off the poles.
glm::vec3 turned(const glm::vec3& from, const glm::vec3& pivot, const glm::vec3& up,
                 const glm::vec2& delta, float height) {
  const UpFrame f(up);
  glm::vec3 d = from - pivot;
  const float r = glm::length(d);
  if (!(r > 0.0f)) return from;
  d /= r;
  const float turn = kPi / std::max(height, 1.0f);
  const float pitch = std::clamp(
      std::asin(std::clamp(glm::dot(d, f.y), -1.0f, 1.0f)) + delta.y * turn, -kMaxPitch, kMaxPitch);
  const float yaw = std::atan2(glm::dot(d, f.x), glm::dot(d, f.z)) - delta.x * turn;
  const glm::vec3 local(std::cos(pitch) * std::sin(yaw), std::sin(pitch),
                        std::cos(pitch) * std::cos(yaw));
  return pivot + r * (local.x * f.x + local.y * f.y + local.z * f.z);
}

}  // namespace

void OrbitCamera::set(const Camera& camera) {
  camera_ = camera;
  if (!(glm::length(camera_.up) > 0.0f)) camera_.up = glm::vec3(0, 1, 0);
}

float OrbitCamera::distance() const {
  return glm::length(camera_.position - camera_.look_at);
}

void OrbitCamera::orbit(const glm::vec2& delta, float height) {
  camera_.position = turned(camera_.position, camera_.look_at, camera_.up, delta, height);
}

void OrbitCamera::pan(const glm::vec2& delta, float height) {
  glm::vec3 right, up, forward;
  viewAxes(camera_, right, up, forward);
  // The view's height at the target's distance, over the pixels.
  const float scale =
      2.0f * distance() * std::tan(0.5f * camera_.vertical_fov) / std::max(height, 1.0f);
  const glm::vec3 move = (-delta.x * right + delta.y * up) * scale;
  camera_.position += move;
  camera_.look_at += move;
}

void OrbitCamera::look(const glm::vec2& delta, float height) {
  // The eye stays; the target turns about it, the other way from orbiting about the target.
  camera_.look_at = turned(camera_.look_at, camera_.position, camera_.up, -delta, height);
}

void OrbitCamera::dolly(float steps) {
  const float d = distance();
  const float to = std::max(d * std::pow(0.85f, steps), 1e-4f);
  camera_.position = camera_.look_at + (camera_.position - camera_.look_at) * (to / d);
}

void OrbitCamera::fly(const glm::vec3& right_up_forward, float scale) {
  glm::vec3 right, up, forward;
  viewAxes(camera_, right, up, forward);
  const glm::vec3 move =
      (right_up_forward.x * right + right_up_forward.y * up + right_up_forward.z * forward) * scale;
  camera_.position += move;
  camera_.look_at += move;
}

}  // namespace penumbra::viewer
