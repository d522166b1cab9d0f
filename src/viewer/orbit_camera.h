// The viewer's camera control: orbit about a target (left drag), pan (middle drag or shift +
// left drag), dolly (scroll), look around from the eye (right drag) and fly (W A S D, Q E down
// and up). Pure math on the library's Camera, so that scripted captures and the window move it
// the same way.
#pragma once

#include "penumbra/scene/camera.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

namespace penumbra::viewer {

class OrbitCamera {
 public:
  OrbitCamera() = default;
  explicit OrbitCamera(const Camera& camera) { set(camera); }

  // The camera as given (kept exactly until a move: a still viewer shows what `render` does).
  void set(const Camera& camera);
  const Camera& camera() const { return camera_; }

  // Mouse deltas in pixels; `height` the view's height in pixels (a drag across it turns half a
  // turn, pans the view's height at the target's distance).
  void orbit(const glm::vec2& delta, float height);
  void pan(const glm::vec2& delta, float height);
  void look(const glm::vec2& delta, float height);
  // Scroll steps: each moves the eye 15% of the way to the target (negative: away).
  void dolly(float steps);
  // Moves eye and target along the view's right, up and forward axes by `amount` of the scene's
  // size `scale` (metres).
  void fly(const glm::vec3& right_up_forward, float scale);

  const glm::vec3& target() const { return camera_.look_at; }
  float distance() const;

 private:
  Camera camera_;
};

}  // namespace penumbra::viewer
