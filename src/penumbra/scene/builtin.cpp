#include "penumbra/scene/builtin.h"

#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>

#include <fmt/format.h>
#include <array>
#include <initializer_list>
#include <utility>

namespace penumbra {

namespace {

// Appends planar polygons (vertex lists in millimetres, counter-clockwise seen from the front)
// as one mesh, fan-triangulated, scaled to metres.
void addPolygons(Scene& scene, const std::string& name, uint32_t material,
                 std::initializer_list<std::initializer_list<std::array<float, 3>>> polygons,
                 float scale) {
  Mesh mesh;
  mesh.name = name;
  for (const auto& poly : polygons) {
    const uint32_t first = static_cast<uint32_t>(mesh.positions.size());
    for (const auto& v : poly)
      mesh.positions.emplace_back(v[0] * scale, v[1] * scale, v[2] * scale);
    for (uint32_t i = 2; i < poly.size(); ++i) {
      mesh.triangles.emplace_back(first, first + i - 1, first + i);
      mesh.material_ids.push_back(material);
    }
  }
  scene.meshes.push_back(std::move(mesh));
}

Scene cornell() {
  // Geometry: the Cornell box data (mitsuba-data cbox meshes), millimetres. The light is moved
  // from the ceiling plane (y = 548.8) down to y = 548.0 so no two surfaces are coplanar.
  Scene s;
  s.source = "builtin:cornell";
  s.materials = {
      {"white", {0.725f, 0.71f, 0.68f}, {0.0f, 0.0f, 0.0f}},
      {"red", {0.63f, 0.065f, 0.05f}, {0.0f, 0.0f, 0.0f}},
      {"green", {0.14f, 0.45f, 0.091f}, {0.0f, 0.0f, 0.0f}},
      {"light", {0.78f, 0.78f, 0.78f}, {17.0f, 12.0f, 4.0f}},
  };
  const float mm = 0.001f;
  addPolygons(s, "floor", 0, {{{552.8f, 0, 0}, {0, 0, 0}, {0, 0, 559.2f}, {549.6f, 0, 559.2f}}},
              mm);
  addPolygons(s, "ceiling", 0,
              {{{556, 548.8f, 0}, {556, 548.8f, 559.2f}, {0, 548.8f, 559.2f}, {0, 548.8f, 0}}}, mm);
  addPolygons(s, "back", 0,
              {{{549.6f, 0, 559.2f}, {0, 0, 559.2f}, {0, 548.8f, 559.2f}, {556, 548.8f, 559.2f}}},
              mm);
  addPolygons(s, "greenwall", 2, {{{0, 0, 559.2f}, {0, 0, 0}, {0, 548.8f, 0}, {0, 548.8f, 559.2f}}},
              mm);
  addPolygons(s, "redwall", 1,
              {{{552.8f, 0, 0}, {549.6f, 0, 559.2f}, {556, 548.8f, 559.2f}, {556, 548.8f, 0}}}, mm);
  addPolygons(s, "smallbox", 0,
              {{{130, 165, 65}, {82, 165, 225}, {240, 165, 272}, {290, 165, 114}},
               {{290, 0, 114}, {290, 165, 114}, {240, 165, 272}, {240, 0, 272}},
               {{130, 0, 65}, {130, 165, 65}, {290, 165, 114}, {290, 0, 114}},
               {{82, 0, 225}, {82, 165, 225}, {130, 165, 65}, {130, 0, 65}},
               {{240, 0, 272}, {240, 165, 272}, {82, 165, 225}, {82, 0, 225}},
               {{290, 0, 114}, {240, 0, 272}, {82, 0, 225}, {130, 0, 65}}},
              mm);
  addPolygons(s, "largebox", 0,
              {{{423, 330, 247}, {265, 330, 296}, {314, 330, 456}, {472, 330, 406}},
               {{423, 0, 247}, {423, 330, 247}, {472, 330, 406}, {472, 0, 406}},
               {{472, 0, 406}, {472, 330, 406}, {314, 330, 456}, {314, 0, 456}},
               {{314, 0, 456}, {314, 330, 456}, {265, 330, 296}, {265, 0, 296}},
               {{265, 0, 296}, {265, 330, 296}, {423, 330, 247}, {423, 0, 247}},
               {{472, 0, 406}, {314, 0, 456}, {265, 0, 296}, {423, 0, 247}}},
              mm);
  // Counter-clockwise seen from below: emits downward only.
  addPolygons(s, "light", 3, {{{343, 548, 227}, {343, 548, 332}, {213, 548, 332}, {213, 548, 227}}},
              mm);
  Camera cam;
  cam.position = glm::vec3(0.278f, 0.273f, -0.800f);
  cam.look_at = glm::vec3(0.278f, 0.273f, 0.0f);
  cam.up = glm::vec3(0.0f, 1.0f, 0.0f);
  cam.vertical_fov = 2.0f * std::atan(12.5f / 35.0f);  // 35 mm lens on 25 mm film: 39.3 degrees
  s.camera = cam;
  return s;
}

Scene furnace() {
  Scene s;
  s.source = "builtin:furnace";
  s.materials = {{"furnace", glm::vec3(0.5f), glm::vec3(1.0f)}};
  addPolygons(s, "cube", 0,
              {{{-1, -1, -1}, {1, -1, -1}, {1, -1, 1}, {-1, -1, 1}},
               {{-1, 1, -1}, {-1, 1, 1}, {1, 1, 1}, {1, 1, -1}},
               {{-1, -1, -1}, {-1, -1, 1}, {-1, 1, 1}, {-1, 1, -1}},
               {{1, -1, -1}, {1, 1, -1}, {1, 1, 1}, {1, -1, 1}},
               {{-1, -1, -1}, {-1, 1, -1}, {1, 1, -1}, {1, -1, -1}},
               {{-1, -1, 1}, {1, -1, 1}, {1, 1, 1}, {-1, 1, 1}}},
              1.0f);
  // Wind every face counter-clockwise as seen from inside, so that it emits inward.
  Mesh& cube = s.meshes.back();
  for (glm::uvec3& t : cube.triangles) {
    const glm::vec3 a = cube.positions[t.x], b = cube.positions[t.y], c = cube.positions[t.z];
    if (glm::dot(glm::cross(b - a, c - a), a + b + c) > 0.0f) std::swap(t.y, t.z);
  }
  Camera cam;
  cam.position = glm::vec3(0.0f);
  cam.look_at = glm::vec3(0.0f, 0.0f, 1.0f);
  cam.vertical_fov = glm::radians(90.0f);
  s.camera = cam;
  return s;
}

}  // namespace

std::vector<std::string> builtinSceneNames() {
  return {"cornell", "furnace", "sss", "lpv", "blobs"};
}

Expected<Scene> builtinScene(const std::string& name) {
  Scene s;
  if (name == "cornell") {
    s = cornell();
  } else if (name == "furnace") {
    s = furnace();
  } else {
    return inputError(
        "", "",
        fmt::format("unknown scene '{}' (built-in scenes: cornell, furnace, sss, lpv, blobs; "
                    "or give a .json, .obj, .gltf, .glb or .ply file)",
                    name));
  }
  Status st = validateScene(s);
  if (!st.ok()) return st.error();
  return s;
}

}  // namespace penumbra
