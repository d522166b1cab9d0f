#include "support/daylight_scenes.h"

#include "penumbra/core/check.h"
#include "penumbra/scene/luminaire.h"
#include "support/test_util.h"

#include <glm/trigonometric.hpp>

namespace penumbra::test {

void setSky(Scene& scene, int type, double e_h, double sun_elevation_deg, double sun_azimuth_deg,
            double sun_lux, double ground_reflectance) {
  Sky sky;
  sky.type = type;
  sky.sun_elevation_deg = sun_elevation_deg;
  sky.sun_azimuth_deg = sun_azimuth_deg;
  sky.north = glm::dvec3(0.0, 0.0, 1.0);
  sky.ground_reflectance = ground_reflectance;
  sky.sun_illuminance = sun_lux;
  sky.prepare();
  sky.zenith_luminance = e_h / sky.horizontalPerZenith();
  if (sun_lux > 0.0) {
    DirectionalLight sun;
    sun.direction = glm::vec3(-sky.sunDirection());
    sun.irradiance = glm::vec3(float(sun_lux / kLumensPerWatt));
    scene.lights.push_back(sun);
  }
  scene.sky = sky;
}

Scene openPlane(float size, glm::vec3 rho) {
  Scene s;
  s.source = "test:open plane";
  Material m{"plane", rho, glm::vec3(0.0f)};
  m.two_sided = false;
  s.materials = {m};
  Mesh mesh;
  mesh.name = "plane";
  // Front face along u x v = +y.
  addQuad(mesh, glm::vec3(0.0f), glm::vec3(0.0f, 0.0f, size), glm::vec3(size, 0.0f, 0.0f), 0);
  s.meshes.push_back(std::move(mesh));
  PENUMBRA_CHECK(validateScene(s).ok());
  return s;
}

Scene closedBox(glm::vec3 rho) {
  Scene s;
  s.source = "test:closed box";
  s.materials = {Material{"box", rho, glm::vec3(0.0f)}};  // two-sided
  s.meshes.push_back(boxMesh(2.0, 1.0, 1.5));
  PENUMBRA_CHECK(validateScene(s).ok());
  return s;
}

Scene windowRoom(bool with_fin) {
  constexpr float kW = 3.0f, kH = 2.5f, kD = 4.0f;
  constexpr float kX0 = 0.75f, kX1 = 2.25f, kY0 = 0.8f, kY1 = 1.8f;  // the window
  Scene s;
  s.source = "test:window room";
  Material wall{"wall", glm::vec3(0.6f, 0.6f, 0.55f), glm::vec3(0.0f)};
  Material floor{"floor", glm::vec3(0.45f, 0.3f, 0.2f), glm::vec3(0.0f)};
  Material ceiling{"ceiling", glm::vec3(0.8f), glm::vec3(0.0f)};
  wall.two_sided = floor.two_sided = ceiling.two_sided = false;
  const Material fin_paint{"fin", glm::vec3(0.5f), glm::vec3(0.0f)};  // two-sided
  s.materials = {wall, floor, ceiling, fin_paint};
  Mesh room;
  room.name = "room";
  const glm::vec3 x(1, 0, 0), y(0, 1, 0), z(0, 0, 1);
  addQuad(room, glm::vec3(0.0f), kD * z, kW * x, 1);            // floor, +y
  addQuad(room, glm::vec3(0.0f, kH, 0.0f), kW * x, kD * z, 2);  // ceiling, -y
  addQuad(room, glm::vec3(0.0f, 0.0f, kD), kH * y, kW * x, 0);  // back wall, -z
  addQuad(room, glm::vec3(0.0f), kH * y, kD * z, 0);            // x = 0, +x
  addQuad(room, glm::vec3(kW, 0.0f, 0.0f), kD * z, kH * y, 0);  // x = W, -x
  // The wall at z = 0 facing +z, around the window.
  addQuad(room, glm::vec3(0.0f), kW * x, kY0 * y, 0);
  addQuad(room, glm::vec3(0.0f, kY1, 0.0f), kW * x, (kH - kY1) * y, 0);
  addQuad(room, glm::vec3(0.0f, kY0, 0.0f), kX0 * x, (kY1 - kY0) * y, 0);
  addQuad(room, glm::vec3(kX1, kY0, 0.0f), (kW - kX1) * x, (kY1 - kY0) * y, 0);
  s.meshes.push_back(std::move(room));
  // A fin left of the window outside (the sun, from the right, does not reach the window past
  // it), lit by the sky, the ground and the sun, and seen from the room through the window.
  if (with_fin) {
    Mesh fin;
    fin.name = "fin";
    addQuad(fin, glm::vec3(0.5f, 0.6f, -0.6f), 0.6f * z, 1.4f * y, 3);
    s.meshes.push_back(std::move(fin));
  }
  Opening window;
  window.name = "window";
  window.corners = {{kX0, kY0, 0.0}, {kX1, kY0, 0.0}, {kX1, kY1, 0.0}, {kX0, kY1, 0.0}};
  window.glazed = true;
  window.transmittance = 0.878;
  s.openings.push_back(window);
  setSky(s, 12, 10000.0, 35.0, 200.0, 10000.0, 0.2);
  Camera camera;
  camera.position = glm::vec3(1.5f, 1.4f, 0.2f);
  camera.look_at = glm::vec3(1.5f, 0.9f, 4.0f);
  camera.vertical_fov = glm::radians(70.0f);
  s.camera = camera;
  PENUMBRA_CHECK(validateScene(s).ok());
  return s;
}

}  // namespace penumbra::test
