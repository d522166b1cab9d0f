#include "support/textured_scenes.h"

#include "penumbra/core/check.h"
#include "penumbra/scene/builtin.h"

#include <glm/geometric.hpp>

#include <cmath>

namespace penumbra::test {

std::shared_ptr<const Texture> makeTexture(const Rgba8Image& image, bool colour) {
  return std::make_shared<const Texture>(
      Texture::fromRgba8("test texture", image.width, image.height, image.texels, colour, 4));
}

Scene chequeredFurnace(uint8_t dark, uint8_t light) {
  Expected<Scene> furnace = builtinScene("furnace");
  PENUMBRA_CHECK(furnace.ok());
  Scene s = std::move(*furnace);
  Mesh& cube = s.meshes[0];
  // Each face's own UVs: its two varying coordinates mapped from [-1, 1] to [0, 1].
  cube.uvs.resize(cube.positions.size());
  for (size_t first = 0; first < cube.positions.size(); first += 4) {
    int fixed = 0;
    for (int a = 0; a < 3; ++a) {
      if (cube.positions[first][a] == cube.positions[first + 2][a]) fixed = a;
    }
    const int u = (fixed + 1) % 3, v = (fixed + 2) % 3;
    for (size_t k = first; k < first + 4; ++k) {
      cube.uvs[k] =
          glm::vec2(0.5f * (cube.positions[k][u] + 1.0f), 0.5f * (cube.positions[k][v] + 1.0f));
    }
  }
  const uint8_t a[4] = {dark, dark, dark, 255}, b[4] = {light, light, light, 255};
  Material& m = s.materials[0];
  m.reflectance = glm::vec3(1.0f);
  m.reflectance_texture = TextureBinding{};
  m.reflectance_texture->texture = makeTexture(chequer(64, 64, 8, a, b), true);
  PENUMBRA_CHECK(validateScene(s).ok());
  return s;
}

namespace {

Mesh quad(const std::string& name, glm::vec3 o, glm::vec3 u, glm::vec3 v, uint32_t material) {
  Mesh m;
  m.name = name;
  m.positions = {o, o + u, o + u + v, o + v};
  m.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  m.material_ids = {material, material};
  return m;
}

}  // namespace

Material maskedLattice(AlphaMode mode) {
  const uint8_t on[4] = {0, 0, 0, 255}, off[4] = {0, 0, 0, 0};
  Material m;
  m.name = "lattice";
  m.reflectance = glm::vec3(0.0f);  // nothing reflects off it
  m.reflectance_texture = TextureBinding{};
  m.reflectance_texture->texture = makeTexture(chequer(64, 64, 8, on, off), true);
  m.alpha_mode = mode;
  return m;
}

Scene floorUnderOccluder(const Material& occluder, float irradiance) {
  Scene s;
  s.source = "test:floor-under-occluder";
  s.materials.push_back({"floor", glm::vec3(0.5f), glm::vec3(0.0f)});
  s.materials.push_back(occluder);
  // Counter-clockwise from above: faces up.
  s.meshes.push_back(quad("floor", {-2, 0, 2}, {4, 0, 0}, {0, 0, -4}, 0));
  s.meshes.push_back(quad("occluder", {-1, 1, 1}, {2, 0, 0}, {0, 0, -2}, 1));
  s.lights.push_back(DirectionalLight{glm::vec3(0, -1, 0), glm::vec3(irradiance)});
  PENUMBRA_CHECK(validateScene(s).ok());
  return s;
}

Material chequeredScreen() {
  const uint8_t red[4] = {255, 0, 0, 255}, green[4] = {0, 255, 0, 255};
  Material screen;
  screen.name = "screen";
  screen.reflectance = glm::vec3(0.0f);
  screen.emission = glm::vec3(3.0f);
  screen.emission_texture = TextureBinding{};
  screen.emission_texture->texture = makeTexture(chequer(32, 32, 4, red, green), true);
  return screen;
}

Scene emitterOverFloor(const Material& emitter, float height) {
  Scene s;
  s.source = "test:emitter-over-floor";
  s.materials.push_back({"floor", glm::vec3(0.5f), glm::vec3(0.0f)});
  s.materials.push_back(emitter);
  s.meshes.push_back(quad("floor", {-50, 0, 50}, {100, 0, 0}, {0, 0, -100}, 0));
  // Counter-clockwise from below: faces down.
  s.meshes.push_back(quad("emitter", {-0.5f, height, -0.5f}, {1, 0, 0}, {0, 0, 1}, 1));
  PENUMBRA_CHECK(validateScene(s).ok());
  return s;
}

double floorMeanUnder(const ChartAtlas& atlas, std::span<const glm::dvec3> radiosity) {
  double sum = 0.0, area = 0.0;
  for (size_t e = 0; e < radiosity.size(); ++e) {
    const glm::dvec3 p = atlas.element_position[e];
    if (std::abs(p.y) > 1e-6 || std::abs(p.x) > 1.0 || std::abs(p.z) > 1.0) continue;
    if (atlas.faces[atlas.element_face[e]].back) continue;
    sum += atlas.element_area[e] * radiosity[e].x;
    area += atlas.element_area[e];
  }
  return sum / area;
}

Scene emitterOverLattice(const Material& lattice) {
  Scene s;
  s.source = "test:emitter-over-lattice";
  s.materials.push_back({"floor", glm::vec3(0.5f), glm::vec3(0.0f)});
  s.materials.push_back(lattice);
  s.materials.push_back({"emitter", glm::vec3(0.0f), glm::vec3(10.0f)});
  s.meshes.push_back(quad("floor", {-2, 0, 2}, {4, 0, 0}, {0, 0, -4}, 0));
  s.meshes.push_back(quad("lattice", {-1, 1, 1}, {2, 0, 0}, {0, 0, -2}, 1));
  s.meshes.push_back(quad("emitter", {-0.5f, 2, -0.5f}, {1, 0, 0}, {0, 0, 1}, 2));
  PENUMBRA_CHECK(validateScene(s).ok());
  return s;
}

}  // namespace penumbra::test
