// Normal mapping (Wallner sec. 3.3): a flat wall whose normal map tilts every normal by the same
// angle receives what the same wall tilted in its geometry receives, and the tangent frames
// follow the UVs (geometry/tangents.h) whichever way they run and in either UV convention.
#include "penumbra/geometry/shading_normals.h"
#include "penumbra/geometry/tangents.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/radiosity/progressive.h"
#include "penumbra/radiosity/radiosity_surface.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>

#include <cmath>
#include <memory>

namespace penumbra {
namespace {

using test::addQuad;

// A 4 x 4 m wall facing +y through the origin, turned by `tilt` radians about the x axis, UVs
// u along the quad's first edge and v along its second (OBJ convention).
Scene wall(double tilt, std::shared_ptr<const Image> map, const Light& light) {
  Scene s;
  s.source = "test:wall";
  Material m{"wall", glm::vec3(0.5f), glm::vec3(0.0f)};
  m.normal_map = std::move(map);
  s.materials = {m};
  Mesh mesh;
  mesh.name = "wall";
  const float c = float(std::cos(tilt)), sn = float(std::sin(tilt));
  // The first edge along +z turned about x, the second along +x: front face (u x v) up.
  const glm::vec3 ez(0.0f, -sn, c), ex(1.0f, 0.0f, 0.0f);
  addQuad(mesh, -2.0f * ez - 2.0f * ex, 4.0f * ez, 4.0f * ex, 0);
  mesh.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  s.meshes.push_back(mesh);
  s.lights.push_back(light);
  return s;
}

// A uniform 4 x 4 normal map whose normal leans `tilt` radians towards +u (the tangent).
std::shared_ptr<const Image> leaningMap(double tilt) {
  auto img = std::make_shared<Image>(4, 4);
  for (glm::vec3& p : img->pixels) {
    p = glm::vec3(float(0.5 + 0.5 * std::sin(tilt)), 0.5f, float(0.5 + 0.5 * std::cos(tilt)));
  }
  return img;
}

// The mean irradiance of the wall's front elements after the lights' shot (B / rho).
double meanIrradiance(const Scene& scene) {
  ProgressiveOptions o;
  o.atlas.texel_density = 4.0;
  Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(scene, o);
  EXPECT_TRUE(pr.ok()) << pr.error().describe();
  if (!pr.ok()) return 0.0;
  pr->shoot(ProgressiveRadiosity::kLights);
  double sum = 0.0, area = 0.0;
  for (size_t e = 0; e < pr->elementCount(); ++e) {
    if (pr->atlas().faces[pr->atlas().element_face[e]].back) continue;
    const double a = pr->surface().atlas.element_area[e];
    sum += pr->radiosity(e).x / 0.5 * a;
    area += a;
  }
  return sum / area;
}

TEST(NormalMap, UniformTiltReceivesWhatTheTiltedWallReceives) {
  // A directional light arriving obliquely; the wall's map leans its normals 25 degrees towards
  // +z (the tangent, u), against the wall itself turned 25 degrees the same way.
  const DirectionalLight sun{glm::normalize(glm::vec3(0.2f, -1.0f, -0.9f)), glm::vec3(3.0f)};
  const double tilt = glm::radians(25.0);
  const double mapped = meanIrradiance(wall(0.0, leaningMap(tilt), sun));
  const double turned = meanIrradiance(wall(tilt, nullptr, sun));
  const double flat = meanIrradiance(wall(0.0, nullptr, sun));
  std::printf("normal-mapped %.4f, tilted %.4f, flat %.4f W/m^2\n", mapped, turned, flat);
  EXPECT_NEAR(mapped / turned, 1.0, 0.02);
  EXPECT_GT(std::abs(turned / flat - 1.0), 0.1);  // the tilt matters: the test can tell
}

TEST(NormalMap, TangentsFollowTheUvsInEitherConvention) {
  // One upward triangle; its map leans the normal towards +u. With u along +x the normal leans
  // to +x; with u along -x to -x; a glTF mesh (v down) leans the same way for the same image
  // when its v runs the other way, and green leans towards up-the-image in both.
  auto lean = [](glm::vec2 a, glm::vec2 b, glm::vec2 c, bool top, glm::vec3 rgb) {
    Scene s;
    s.materials = {{"m", glm::vec3(0.5f), glm::vec3(0.0f)}};
    Mesh m;
    m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 0, -1}};  // counter-clockwise from above: +y
    m.triangles = {{0, 1, 2}};
    m.material_ids = {0};
    m.uvs = {a, b, c};
    m.uv_origin_top = top;
    s.meshes.push_back(m);
    const std::vector<glm::vec3> normals = cornerShadingNormals(s);
    const std::vector<glm::vec4> t = cornerTangents(s, normals);
    return perturbedNormal(glm::dvec3(normals[0]), t[0], rgb, 1.0f);
  };
  const glm::vec3 red(0.8f, 0.5f, 0.9f), green(0.5f, 0.8f, 0.9f);
  // u along +x, v along -z (up the image = -z).
  EXPECT_GT(lean({0, 0}, {1, 0}, {0, 1}, false, red).x, 0.2);
  EXPECT_LT(lean({0, 0}, {1, 0}, {0, 1}, false, green).z, -0.2);
  // u along -x.
  EXPECT_LT(lean({1, 0}, {0, 0}, {1, 1}, false, red).x, -0.2);
  // glTF: v down the image, so the same layout in the picture has v = 1 - v.
  EXPECT_GT(lean({0, 1}, {1, 1}, {0, 0}, true, red).x, 0.2);
  EXPECT_LT(lean({0, 1}, {1, 1}, {0, 0}, true, green).z, -0.2);
  // A flat (0.5, 0.5, 1) map leaves the normal alone.
  EXPECT_NEAR(lean({0, 0}, {1, 0}, {0, 1}, false, {0.5f, 0.5f, 1.0f}).y, 1.0, 1e-9);
}

TEST(NormalMap, LightmapDensityFollowsTheMap) {
  // The brick wall: a 256 x 256 map repeated twice each way over 2 x 2 m is 256 texels per
  // metre; the automatic lightmap density rises towards it, by at most a factor of 2.
  Expected<Scene> s = loadScene(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/brick_wall.json");
  ASSERT_TRUE(s.ok()) << s.error().describe();
  EXPECT_NEAR(normalMapTexelDensity(*s), 256.0, 1e-6);
  LightmapResolution r;
  r.elements = 40000;
  Expected<ChartAtlasOptions> o = lightmapAtlasOptions(*s, r);
  ASSERT_TRUE(o.ok());
  EXPECT_NEAR(o->texel_density, 2.0 * texelDensityFor(*s, 40000), 1e-9);
  EXPECT_NEAR(double(expectedLightmapElements(*s, r)), 4.0 * 40000.0, 1.0);
  r.elements = 4000000;  // finer than the map already: unchanged
  Expected<ChartAtlasOptions> fine = lightmapAtlasOptions(*s, r);
  ASSERT_TRUE(fine.ok());
  EXPECT_NEAR(fine->texel_density, texelDensityFor(*s, 4000000), 1e-9);
  Scene plain = *s;
  for (Material& m : plain.materials) m.normal_map.reset();
  EXPECT_EQ(normalMapTexelDensity(plain), 0.0);
}

}  // namespace
}  // namespace penumbra
