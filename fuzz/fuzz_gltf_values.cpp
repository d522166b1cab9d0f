// glTF values (fuzz/value_mutator.h) on a document that uses what Blender's exporter writes: a
// textured material with its factors and a texture transform, nodes with a matrix and with TRS,
// a camera and KHR_lights_punctual lights. A file that loads must hold finite numbers.
#include "fuzz_util.h"
#include "value_mutator.h"
#include "value_templates.h"

#include "penumbra/io/scene_io.h"

#include <cmath>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace penumbra;
  // A quad: 4 positions, normals and UVs (32 bytes a vertex), 6 indices; a 1 x 1 PNG texture.
  static const nlohmann::json base = fuzz::quadGltf();
  const std::string text =
      fuzz::mutateValues(base, std::string_view(reinterpret_cast<const char*>(data), size));
  const std::string path = fuzz::writeInput("x.gltf", text);
  Expected<Scene> scene = loadGltf(path);
  fuzz::expectContract(scene, path);
  if (!scene.ok()) return 0;
  for (const Mesh& m : scene->meshes) {
    for (const glm::vec3& p : m.positions) {
      if (!(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))) std::abort();
    }
  }
  for (const Material& m : scene->materials) {
    if (!(m.reflectance.x >= 0.0f && m.reflectance.x <= 1.0f)) std::abort();
  }
  return 0;
}
