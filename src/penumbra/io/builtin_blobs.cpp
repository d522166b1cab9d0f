// The built-in animated scene `blobs`: two jade-like blobs, the level set of two metaballs, that
// move together along x and merge halfway through (one mesh whose topology changes from two
// components to one), on a grey floor, lit from the side, above and a little behind by a point
// light. Marching tetrahedra remesh it at every time (geometry/isosurface.h).
#include "penumbra/geometry/isosurface.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/media.h"

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <cmath>

namespace penumbra {

namespace {

constexpr double kRadius = 0.02;  // m, each blob alone

Expected<Scene> blobsAt(double t) {
  if (!(t >= 0.0 && t <= 1.0)) return inputError("", "blobs", "the time must be in [0, 1]");
  Scene s;
  s.source = "builtin:blobs";
  // The centres approach from 9 cm apart to 1 cm: the surfaces touch near t = 0.6.
  const double half = 0.045 * (1.0 - t) + 0.005 * t;
  const glm::dvec3 c0(-half, kRadius * 1.2, 0.0), c1(half, kRadius * 1.2, 0.0);
  const auto field = [&](const glm::dvec3& p) {
    const auto ball = [&](const glm::dvec3& c) {
      const glm::dvec3 d = p - c;
      return kRadius * kRadius / (glm::dot(d, d) + 1e-12);
    };
    return ball(c0) + ball(c1) - 1.0;
  };
  const glm::dvec3 margin(kRadius * 1.6);
  Mesh blobs = isosurfaceMesh(field, glm::min(c0, c1) - margin, glm::max(c0, c1) + margin, 56);
  blobs.name = "blobs";
  s.meshes.push_back(std::move(blobs));
  // Jade-like: green, light diffusing centimetres (albedo and diffusion length per channel,
  // scene/media.h).
  Expected<Subsurface> jade_medium =
      subsurfaceFromAlbedo(glm::dvec3(0.55, 0.85, 0.6), glm::dvec3(0.004, 0.008, 0.005), 1.5);
  if (!jade_medium) return jade_medium.error();
  Material jade;
  jade.name = "jade";
  jade.subsurface = *jade_medium;
  jade.reflectance = glm::vec3(glm::clamp(lambertianAlbedo(*jade.subsurface), 0.0, 1.0));
  jade.two_sided = false;
  s.materials.push_back(jade);
  // The floor, 30 cm square at y = 0, facing up.
  Mesh floor;
  floor.name = "floor";
  const float f = 0.15f;
  floor.positions = {{-f, 0, -f}, {f, 0, -f}, {f, 0, f}, {-f, 0, f}};
  floor.triangles = {{0, 2, 1}, {0, 3, 2}};
  floor.material_ids = {1, 1};
  s.meshes.push_back(floor);
  Material white;
  white.name = "floor";
  white.reflectance = glm::vec3(0.3f);
  s.materials.push_back(white);
  s.lights.push_back(PointLight{glm::vec3(0.1f, 0.12f, -0.06f), glm::vec3(0.5f)});
  Camera c;
  c.position = glm::vec3(0.0f, 0.09f, 0.3f);
  c.look_at = glm::vec3(0.0f, 0.025f, 0.0f);
  c.vertical_fov = 0.5f;
  s.camera = c;
  PENUMBRA_TRY(validateScene(s));
  return s;
}

}  // namespace

std::optional<SceneAnimation> builtinAnimation(const std::string& name) {
  if (name == "blobs") return SceneAnimation(blobsAt);
  return std::nullopt;
}

}  // namespace penumbra
