// The viewer's camera control and scripts, without a window: orbiting keeps the distance to the
// target, panning moves eye and target together across the view, looking around keeps the eye,
// a camera survives the round trip through the control, and script paths are followed linearly.
#include "viewer/orbit_camera.h"
#include "penumbra/raytrace/camera_rays.h"
#include "support/test_util.h"
#include "viewer/script.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

namespace penumbra::viewer {
namespace {

void expectNear(const glm::vec3& a, const glm::vec3& b, float tol) {
  EXPECT_LT(glm::length(a - b), tol)
      << a.x << " " << a.y << " " << a.z << " vs " << b.x << " " << b.y << " " << b.z;
}

TEST(OrbitCamera, MovesAsTheMouseSays) {
  Camera c;
  c.position = glm::vec3(0.3f, 0.4f, -1.2f);
  c.look_at = glm::vec3(0.1f, 0.2f, 0.3f);
  c.vertical_fov = 0.7f;
  OrbitCamera o(c);
  // Kept exactly until moved: the still viewer's camera is the scene's, to the bit.
  EXPECT_EQ(o.camera().position, c.position);
  EXPECT_EQ(o.camera().look_at, c.look_at);
  EXPECT_EQ(o.camera().vertical_fov, c.vertical_fov);

  // Orbit: the target stays, the distance stays, the eye moves.
  const float d = glm::length(c.position - c.look_at);
  o.orbit(glm::vec2(120.0f, -40.0f), 600.0f);
  expectNear(o.camera().look_at, c.look_at, 1e-6f);
  EXPECT_NEAR(glm::length(o.camera().position - o.camera().look_at), d, 1e-5f);
  EXPECT_GT(glm::length(o.camera().position - c.position), 0.1f);

  // Pan: eye and target move by the same vector, across the view; a point at the target's depth
  // follows the mouse by the dragged pixels.
  const Camera before = o.camera();
  const CameraRays rays(before, 800, 600);
  o.pan(glm::vec2(50.0f, 20.0f), 600.0f);
  const Camera after = o.camera();
  const glm::vec3 moved = after.look_at - before.look_at;
  expectNear(after.position - before.position, moved, 1e-5f);
  EXPECT_NEAR(glm::dot(moved, glm::normalize(before.look_at - before.position)), 0.0f, 1e-5f);
  // The scene moves with the mouse: what was under (400, 300) is now under (450, 320).
  const std::optional<glm::vec2> seen = CameraRays(after, 800, 600).project(before.look_at);
  ASSERT_TRUE(seen.has_value());
  EXPECT_NEAR(seen->x, 450.0f, 0.05f);
  EXPECT_NEAR(seen->y, 320.0f, 0.05f);
  (void)rays;

  // Look around: the eye stays.
  const glm::vec3 eye = o.camera().position;
  o.look(glm::vec2(-80.0f, 30.0f), 600.0f);
  expectNear(o.camera().position, eye, 1e-5f);

  // Dolly: towards the target.
  const float before_d = o.distance();
  o.dolly(2.0f);
  EXPECT_NEAR(o.distance(), before_d * 0.85f * 0.85f, 1e-5f);
}

TEST(CameraRays, ProjectIsTheInverseOfTheRays) {
  Camera c;
  c.position = glm::vec3(1, 2, 3);
  c.look_at = glm::vec3(0.5f, 1.5f, 0.0f);
  const CameraRays rays(c, 320, 200);
  for (const glm::vec2 px : {glm::vec2(0.5f, 0.5f), glm::vec2(160, 100), glm::vec2(300.2f, 17)}) {
    const glm::vec3 p = rays.unproject(px.x, px.y, 2.5f);
    float depth = 0.0f;
    const std::optional<glm::vec2> back = rays.project(p, &depth);
    ASSERT_TRUE(back.has_value());
    EXPECT_NEAR(back->x, px.x, 1e-3f);
    EXPECT_NEAR(back->y, px.y, 1e-3f);
    EXPECT_NEAR(depth, 2.5f, 1e-5f);
    // On the pixel's ray.
    const Ray r = rays.ray(px.x, px.y);
    EXPECT_LT(glm::length(glm::cross(p - r.origin, r.dir)), 1e-5f);
  }
  EXPECT_FALSE(rays.project(c.position - (c.look_at - c.position)).has_value());
}

TEST(ViewerScript, PathsAreFollowedLinearlyAndBadKeysNamed) {
  test::TempDir dir;
  const std::string path =
      dir.write("s.json", R"({"light": 1, "light_path": [[0, 0, 0], [2, 0, 0], [2, 4, 0]],
                    "camera_path": [{"position": [0, 0, 1], "look_at": [0, 0, 0]}]})");
  Expected<Script> s = readScript(path);
  ASSERT_TRUE(s.ok()) << s.error().describe();
  EXPECT_EQ(s->light, 1);
  expectNear(*s->lightAt(0, 5), glm::vec3(0, 0, 0), 1e-6f);
  expectNear(*s->lightAt(1, 5), glm::vec3(1, 0, 0), 1e-6f);
  expectNear(*s->lightAt(2, 5), glm::vec3(2, 0, 0), 1e-6f);
  expectNear(*s->lightAt(3, 5), glm::vec3(2, 2, 0), 1e-6f);
  expectNear(*s->lightAt(4, 5), glm::vec3(2, 4, 0), 1e-6f);
  expectNear(s->cameraAt(3, 5)->position, glm::vec3(0, 0, 1), 1e-6f);
  const struct {
    const char* json;
    const char* place;
  } bad[] = {
      {R"({"light_path": []})", "light_path"},
      {R"({"light_path": [[0, 0, "x"]]})", "light_path[0]"},
      {R"({"camera_path": [{"position": [0, 0, 0]}]})", "camera_path[0]"},
      {R"({"camera_path": [{"position": [1, 1, 1], "look_at": [1, 1, 1]}]})", "camera_path[0]"},
      {R"({"lights": 0})", "lights"},
      {R"({"drop": {"frame": -1, "file": "a.obj"}})", "drop"},
      {R"([1, 2)", "s.json"}};
  for (const auto& b : bad) {
    const std::string f = dir.write("s.json", b.json);
    Expected<Script> r = readScript(f);
    ASSERT_FALSE(r.ok()) << b.json;
    EXPECT_NE(r.error().describe().find(b.place), std::string::npos) << r.error().describe();
  }
}

}  // namespace
}  // namespace penumbra::viewer
