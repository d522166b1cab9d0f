#include "support/sss_scenes.h"

#include "penumbra/io/scene_io.h"
#include "penumbra/scene/media.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

namespace penumbra::test {

namespace {

Material emitter(float radiance) {
  Material light;
  light.name = "light";
  light.reflectance = glm::vec3(0.0f);
  light.emission = glm::vec3(radiance);
  light.two_sided = false;
  return light;
}

}  // namespace

Mesh squareEmitter(const glm::vec3& at, const glm::vec3& n, float size, uint32_t material) {
  const glm::vec3 helper = std::abs(n.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
  const glm::vec3 u = glm::normalize(glm::cross(n, helper)) * (0.5f * size);
  const glm::vec3 v = glm::cross(u, n);
  Mesh quad;
  quad.name = "light";
  quad.positions = {at - u - v, at + u - v, at + u + v, at - u + v};
  // Counter-clockwise seen from the side n points to.
  const bool ccw = glm::dot(glm::cross(quad.positions[1] - quad.positions[0],
                                       quad.positions[2] - quad.positions[0]),
                            n) > 0.0f;
  quad.triangles = ccw ? std::vector<glm::uvec3>{{0, 1, 2}, {0, 2, 3}}
                       : std::vector<glm::uvec3>{{0, 2, 1}, {0, 3, 2}};
  quad.material_ids = {material, material};
  return quad;
}

Scene areaLitBunny() {
  Expected<Scene> loaded = loadScene("sss");
  EXPECT_TRUE(loaded.ok());
  Scene s = std::move(*loaded);
  s.lights.clear();
  s.environment = glm::vec3(0.02f);
  s.materials.push_back(emitter(4.0f));
  const glm::vec3 centre(-0.017f, 0.11f, 0.0f);
  const glm::vec3 at(0.25f, 0.2f, -0.3f);
  s.meshes.push_back(
      squareEmitter(at, glm::normalize(centre - at), 0.3f, uint32_t(s.materials.size() - 1)));
  EXPECT_TRUE(validateScene(s).ok());
  return s;
}

Scene areaLitMarbleSlab(double thickness_mm, float radiance) {
  Scene s;
  s.source = "slab";
  s.meshes.push_back(boxMesh(0.02, thickness_mm * 1e-3, 0.02));
  Material m;
  m.name = "marble";
  m.subsurface = subsurfacePreset("marble");
  m.two_sided = false;
  s.materials.push_back(m);
  s.materials.push_back(emitter(radiance));
  const float top = float(thickness_mm * 1e-3);
  s.meshes.push_back(
      squareEmitter(glm::vec3(0.01f, top + 0.03f, 0.01f), glm::vec3(0, -1, 0), 0.06f, 1));
  Camera cam;
  // Under the emitter, 20 mm above the top.
  cam.position = glm::vec3(0.01f, top + 0.02f, 0.01f);
  cam.look_at = glm::vec3(0.01f, 0.0f, 0.01f);
  cam.up = glm::vec3(0, 0, 1);
  cam.vertical_fov = 0.1f;  // 2 mm at 20 mm
  s.camera = cam;
  EXPECT_TRUE(validateScene(s).ok());
  return s;
}

}  // namespace penumbra::test
