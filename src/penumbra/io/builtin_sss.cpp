// The built-in `sss` and `lpv` scenes. `sss`: the Stanford bunny (69,451 triangles, its file
// embedded in the library) in Jensen et al.'s measured marble, lit from behind and from the side by
// two point lights, as Carr, Hall, Hart 2003 (Fig. 7) show translucency: light through the ears and
// the thin parts.
#include "penumbra/io/scene_io.h"
#include "penumbra/scene/media.h"

#include <fmt/format.h>
#include <glm/common.hpp>

extern "C" const char penumbra_embedded_bunny_ply[];
extern "C" const char penumbra_embedded_bunny_ply_end[];

namespace penumbra {

namespace {

Expected<Scene> marbleBunny(const char* source) {
  const std::string bytes(penumbra_embedded_bunny_ply,
                          size_t(penumbra_embedded_bunny_ply_end - penumbra_embedded_bunny_ply));
  Expected<Scene> s = loadPlyBytes(fmt::format("{} (bunny.ply)", source), bytes);
  if (!s) return s.error();
  s->source = source;
  s->meshes[0].name = "bunny";
  Material& marble = s->materials[0];
  marble.name = "marble";
  marble.subsurface = subsurfacePreset("marble");
  marble.reflectance = glm::vec3(glm::clamp(lambertianAlbedo(*marble.subsurface), 0.0, 1.0));
  marble.two_sided = false;
  Camera c;
  c.position = glm::vec3(-0.017f, 0.115f, 0.42f);
  c.look_at = glm::vec3(-0.017f, 0.11f, 0.0f);
  c.vertical_fov = 0.45f;
  s->camera = c;
  return s;
}

}  // namespace

Expected<Scene> lpvBuiltinScene() {
  Expected<Scene> s = marbleBunny("builtin:lpv");
  if (!s) return s.error();
  // Behind the bunny (it faces +z), a little above: light through the ears and the thin parts.
  s->lights.push_back(PointLight{glm::vec3(-0.05f, 0.25f, -0.35f), glm::vec3(0.8f)});
  PENUMBRA_TRY(validateScene(*s));
  return s;
}

Expected<Scene> sssBuiltinScene() {
  Expected<Scene> s = marbleBunny("builtin:sss");
  if (!s) return s.error();
  // The bunny spans x -0.095..0.061, y 0.033..0.187, z -0.062..0.059 m; it faces +z.
  s->lights.push_back(PointLight{glm::vec3(-0.05f, 0.25f, -0.35f), glm::vec3(0.6f)});  // behind
  s->lights.push_back(PointLight{glm::vec3(0.45f, 0.12f, 0.05f), glm::vec3(0.15f)});   // side
  PENUMBRA_TRY(validateScene(*s));
  return s;
}

}  // namespace penumbra
