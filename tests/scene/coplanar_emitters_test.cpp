// Emitters drawn on another surface (scene/coplanar_emitters.h): a panel on an unbroken ceiling
// is lifted off it and said so; a panel filling a hole, or touching the ceiling only at its
// edges, is left alone; a panel sharing the ceiling's mesh and vertices moves without moving
// the ceiling; lifting twice lifts nothing more.
#include "penumbra/scene/coplanar_emitters.h"
#include "support/test_util.h"

#include <gtest/gtest.h>

namespace penumbra {
namespace {

using test::addQuad;

Scene ceilingScene() {
  Scene s;
  s.source = "test:ceiling";
  s.materials = {{"paint", glm::vec3(0.7f), glm::vec3(0.0f)},
                 {"panel", glm::vec3(0.0f), glm::vec3(5.0f)}};
  return s;
}

TEST(CoplanarEmitters, APanelOnTheCeilingIsLiftedAlongItsFront) {
  Scene s = ceilingScene();
  Mesh ceiling;
  ceiling.name = "ceiling";
  addQuad(ceiling, {0, 3, 0}, {4, 0, 0}, {0, 0, 4}, 0);  // facing down
  Mesh panel;
  panel.name = "panel";
  addQuad(panel, {1.5f, 3, 1.5f}, {1, 0, 0}, {0, 0, 1}, 1);
  s.meshes = {ceiling, panel};
  EXPECT_EQ(liftCoplanarEmitters(s), 2u);
  for (const glm::vec3& p : s.meshes[0].positions) EXPECT_EQ(p.y, 3.0f);
  for (const glm::uvec3& t : s.meshes[1].triangles) {
    for (int k = 0; k < 3; ++k) {
      const float y = s.meshes[1].positions[t[k]].y;
      EXPECT_LT(y, 3.0f);
      EXPECT_GT(y, 3.0f - 1e-3f);  // 1e-4 of the 1.41 m diagonal
    }
  }
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("2 triangle(s) of emitter 'panel' lie on 'ceiling'"),
            std::string::npos)
      << s.warnings[0];
  EXPECT_EQ(liftCoplanarEmitters(s), 0u) << "lifted once is lifted for good";
}

TEST(CoplanarEmitters, APanelInAHoleOrBesideTheCeilingIsLeftAlone) {
  Scene s = ceilingScene();
  Mesh ceiling;
  ceiling.name = "ceiling";
  // The ceiling around a 1 m hole at (1.5..2.5)^2.
  addQuad(ceiling, {0, 3, 0}, {1.5f, 0, 0}, {0, 0, 4}, 0);
  addQuad(ceiling, {2.5f, 3, 0}, {1.5f, 0, 0}, {0, 0, 4}, 0);
  addQuad(ceiling, {1.5f, 3, 0}, {1, 0, 0}, {0, 0, 1.5f}, 0);
  addQuad(ceiling, {1.5f, 3, 2.5f}, {1, 0, 0}, {0, 0, 1.5f}, 0);
  Mesh panel;
  addQuad(panel, {1.5f, 3, 1.5f}, {1, 0, 0}, {0, 0, 1}, 1);
  // And one parallel to the ceiling but 1 cm below it.
  addQuad(panel, {0.2f, 2.99f, 0.2f}, {0.5f, 0, 0}, {0, 0, 0.5f}, 1);
  s.meshes = {ceiling, panel};
  const std::vector<glm::vec3> before = s.meshes[1].positions;
  EXPECT_EQ(liftCoplanarEmitters(s), 0u);
  EXPECT_EQ(s.meshes[1].positions, before);
  EXPECT_TRUE(s.warnings.empty());
}

TEST(CoplanarEmitters, APanelSharingTheCeilingsVerticesMovesAlone) {
  // One mesh: the ceiling as a 2 x 2 grid of quads over shared vertices, the middle... here the
  // quad (1..2, 1..2) of a 3 x 3 grid is emissive, and an unbroken ceiling quad lies under all.
  Scene s = ceilingScene();
  Mesh m;
  m.name = "ceiling";
  for (int z = 0; z <= 3; ++z) {
    for (int x = 0; x <= 3; ++x) m.positions.emplace_back(float(x), 3.0f, float(z));
  }
  const auto at = [](int x, int z) { return uint32_t(z * 4 + x); };
  for (int z = 0; z < 3; ++z) {
    for (int x = 0; x < 3; ++x) {
      const uint32_t mat = (x == 1 && z == 1) ? 1 : 0;
      // Facing down: (x, z), (x + 1, z), (x + 1, z + 1).
      m.triangles.emplace_back(at(x, z), at(x + 1, z), at(x + 1, z + 1));
      m.triangles.emplace_back(at(x, z), at(x + 1, z + 1), at(x, z + 1));
      m.material_ids.insert(m.material_ids.end(), {mat, mat});
    }
  }
  Mesh slab;
  slab.name = "slab";
  addQuad(slab, {0, 3, 0}, {3, 0, 0}, {0, 0, 3}, 0);
  s.meshes = {m, slab};
  const size_t vertices = s.meshes[0].positions.size();
  EXPECT_EQ(liftCoplanarEmitters(s), 2u);
  EXPECT_EQ(s.meshes[0].positions.size(), vertices + 4);  // the panel's four corners, copied
  for (size_t v = 0; v < vertices; ++v) EXPECT_EQ(s.meshes[0].positions[v].y, 3.0f) << v;
  for (size_t t = 8; t < 10; ++t) {
    for (int k = 0; k < 3; ++k) EXPECT_GE(s.meshes[0].triangles[t][k], vertices);
  }
}

}  // namespace
}  // namespace penumbra
