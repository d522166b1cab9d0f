// The JSON scene's values (fuzz/value_mutator.h) on a scene that uses every kind of entry: a
// material with emission, a mesh file and a sphere placed by transforms, point, spot and
// directional lights, a luminaire array, a camera, an environment and settings. A scene that
// loads must hold finite, checked numbers, and its settings must apply or give an input error.
#include "fuzz_util.h"
#include "value_mutator.h"
#include "value_templates.h"

#include "penumbra/io/scene_io.h"
#include "penumbra/methods/registry.h"
#include "penumbra/scene/light.h"

#include <cmath>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace penumbra;
  static const std::string mesh =
      fuzz::writeInput("m.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
  static const std::string ldt = fuzz::writeInput("l.ldt", fuzz::sampleLdt());
  static const nlohmann::json base = nlohmann::json::parse(R"({
    "materials": {"white": {"reflectance": [0.8, 0.8, 0.8]},
                  "lamp": {"reflectance": 0.5, "emission": [4, 4, 4]}},
    "meshes": [
      {"file": "m.obj", "material": "white",
       "transform": {"translate": [0, 0, 0], "rotate_deg": [0, 30, 0], "scale": [2, 2, 2]}},
      {"sphere": 1, "material": "lamp",
       "transform": {"matrix": [0.2, 0, 0, 0.5, 0, 0.2, 0, 1, 0, 0, 0.2, 0.5, 0, 0, 0, 1]}}],
    "lights": [
      {"type": "point", "position": [0.5, 1.5, 0.5], "intensity": [1, 1, 1]},
      {"type": "spot", "position": [0, 2, 0], "direction": [0, -1, 0], "intensity": 3,
       "inner_angle_deg": 10, "outer_angle_deg": 30},
      {"type": "directional", "direction": [0, -1, 0.2], "irradiance": [2, 2, 2]},
      {"type": "luminaire", "file": "l.ldt", "position": [0.5, 2, 0.5], "aim": [0, -1, 0],
       "dimming": 0.5, "rotation_deg": 15, "array": {"count": [2, 2], "spacing": [0.5, 0.5]}}],
    "camera": {"position": [0.5, 0.5, 3], "look_at": [0.5, 0.5, 0], "fov_deg": 40},
    "environment": [0.1, 0.1, 0.1],
    "settings": {"pathtrace": {"spp": 4, "width": 16, "height": 16, "max_depth": 3},
                 "progressive": {"texel_density": 20, "iterations": 10}}
  })");
  const std::string text =
      fuzz::mutateValues(base, std::string_view(reinterpret_cast<const char*>(data), size));
  const std::string path = fuzz::writeInput("x.json", text);
  Expected<Scene> scene = loadSceneJson(path);
  fuzz::expectContract(scene, path);
  if (!scene.ok()) return 0;
  for (const Mesh& m : scene->meshes) {
    for (const glm::vec3& p : m.positions) {
      if (!(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))) std::abort();
    }
  }
  for (const char* method : {"pathtrace", "progressive", "stochastic", "matrix", "whitted"}) {
    RenderOptions options;
    options.method = method;
    fuzz::expectContract(applySceneSettings(options, scene->settings, path, {}), path);
  }
  return 0;
}
