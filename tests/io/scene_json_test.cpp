// The JSON scene format: the repository's scenes/cornell.json against the built-in Cornell box,
// transforms (order, normals, mirroring), materials, lights, camera, settings, the example in
// docs/scene-format.md, strictness (unknown keys, types, lengths) and parse errors with line and
// column; and the loadScene / loadSceneFile dispatchers.
#include "penumbra/io/scene_io.h"
#include "penumbra/kernels/dipole.h"
#include "penumbra/scene/builtin.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>

namespace penumbra {
namespace {

using test::dataPath;
using test::errorNames;
using test::TempDir;

const std::string kRepo = std::string(PENUMBRA_TEST_DATA) + "/../..";

std::string readAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void bounds(const Scene& s, glm::vec3* lo, glm::vec3* hi) {
  *lo = glm::vec3(INFINITY);
  *hi = glm::vec3(-INFINITY);
  for (const Mesh& m : s.meshes) {
    for (const glm::vec3& p : m.positions) {
      *lo = glm::min(*lo, p);
      *hi = glm::max(*hi, p);
    }
  }
}

void expectNear(const glm::vec3& a, const glm::vec3& b, float tol = 1e-5f) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}

// Emitted power per material, sum of area x radiance: compares emitters independently of how
// each scene splits its meshes.
glm::vec3 emittedRadianceArea(const Scene& s) {
  glm::vec3 sum(0.0f);
  for (const Mesh& m : s.meshes) {
    for (size_t t = 0; t < m.triangles.size(); ++t) {
      const glm::uvec3 tri = m.triangles[t];
      const glm::vec3 c = glm::cross(m.positions[tri.y] - m.positions[tri.x],
                                     m.positions[tri.z] - m.positions[tri.x]);
      sum += 0.5f * glm::length(c) * s.materials[m.material_ids[t]].emission;
    }
  }
  return sum;
}

TEST(SceneJsonLoad, CornellMatchesBuiltin) {
  Expected<Scene> json_scene = loadSceneJson(kRepo + "/scenes/cornell.json");
  ASSERT_TRUE(json_scene.ok()) << json_scene.error().describe();
  Expected<Scene> builtin = builtinScene("cornell");
  ASSERT_TRUE(builtin.ok()) << builtin.error().describe();
  EXPECT_EQ(json_scene->triangleCount(), builtin->triangleCount());
  EXPECT_TRUE(json_scene->warnings.empty()) << json_scene->warnings[0];
  glm::vec3 lo_j, hi_j, lo_b, hi_b;
  bounds(*json_scene, &lo_j, &hi_j);
  bounds(*builtin, &lo_b, &hi_b);
  expectNear(lo_j, lo_b, 1e-6f);
  expectNear(hi_j, hi_b, 1e-6f);
  expectNear(hi_j, {0.556f, 0.5488f, 0.5592f}, 1e-6f);
  // The same light: 0.130 m x 0.105 m emitting (17, 12, 4), facing down.
  expectNear(emittedRadianceArea(*json_scene), emittedRadianceArea(*builtin), 1e-4f);
  expectNear(emittedRadianceArea(*json_scene), 0.130f * 0.105f * glm::vec3(17, 12, 4), 1e-4f);
  for (const Mesh& m : json_scene->meshes) {
    if (m.name != "luminaire") continue;
    const glm::uvec3 t = m.triangles[0];
    const glm::vec3 n =
        glm::cross(m.positions[t.y] - m.positions[t.x], m.positions[t.z] - m.positions[t.x]);
    EXPECT_LT(n.y, 0.0f);
    EXPECT_FLOAT_EQ(m.positions[0].y, 0.548f);
  }
  ASSERT_TRUE(json_scene->camera.has_value());
  expectNear(json_scene->camera->position, builtin->camera->position);
  expectNear(json_scene->camera->look_at, builtin->camera->look_at);
  EXPECT_NEAR(json_scene->camera->vertical_fov, builtin->camera->vertical_fov, 1e-5f);
  // Through the dispatchers.
  Expected<Scene> via = loadScene(kRepo + "/scenes/cornell.json");
  ASSERT_TRUE(via.ok()) << via.error().describe();
  EXPECT_EQ(via->triangleCount(), builtin->triangleCount());
}

TEST(SceneJsonLoad, DocumentedExampleIsTheRepositoryScene) {
  // docs/scene-format.md shows scenes/cornell.json in its first json block.
  const std::string doc = readAll(kRepo + "/docs/scene-format.md");
  const size_t start = doc.find("```json\n");
  ASSERT_NE(start, std::string::npos);
  const size_t end = doc.find("```", start + 8);
  const nlohmann::json shown =
      nlohmann::json::parse(doc.substr(start + 8, end - start - 8), nullptr, true, true);
  const nlohmann::json file =
      nlohmann::json::parse(readAll(kRepo + "/scenes/cornell.json"), nullptr, true, true);
  EXPECT_EQ(shown, file);
}

const char* const kTriangleObj =
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0.70710678 0.70710678 0\nf 1//1 2//1 3//1\n";

TEST(SceneJsonLoad, TwoSidedIsTheDefaultAndCanBeTurnedOff) {
  TempDir dir;
  dir.write("tri.obj", kTriangleObj);
  const std::string path = dir.write("scene.json", R"({
    "materials": {"paint": {}, "sheet": {"two_sided": false}},
    "meshes": [{"file": "tri.obj", "material": "paint"}, {"file": "tri.obj", "material": "sheet"}]
  })");
  Expected<Scene> s = loadSceneJson(path);
  ASSERT_TRUE(s.ok()) << s.error().describe();
  EXPECT_TRUE(s->materials[0].two_sided);
  EXPECT_FALSE(s->materials[1].two_sided);
  const std::string bad = dir.write("bad.json", R"({
    "materials": {"sheet": {"two_sided": 0}},
    "meshes": [{"file": "tri.obj", "material": "sheet"}]
  })");
  EXPECT_TRUE(errorNames(loadSceneJson(bad), bad, "materials.sheet.two_sided"));
}

// "type": "mirror" and "glass" with their "specular" colour and "ior"; the radiosity methods'
// stand-in reflectance (scene/scene.h); "sphere" meshes; and the errors, each naming its key.
TEST(SceneJsonLoad, MirrorAndGlassMaterialsAndSpheres) {
  TempDir dir;
  dir.write("tri.obj", kTriangleObj);
  const std::string path = dir.write("scene.json", R"({
    "materials": {"chrome": {"type": "mirror", "specular": [0.9, 0.8, 0.7]},
                  "crown": {"type": "glass", "ior": 1.52, "specular": [1, 1, 0.9]},
                  "plain": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}},
    "meshes": [{"file": "tri.obj", "material": "plain"},
               {"sphere": 2, "material": "crown",
                "transform": {"scale": 0.5, "translate": [1, 2, 3]}},
               {"sphere": 0, "material": "chrome"}]
  })");
  Expected<Scene> s = loadSceneJson(path);
  ASSERT_TRUE(s.ok()) << s.error().describe();
  ASSERT_EQ(s->materials.size(), 3u);  // sorted by name: chrome, crown, plain
  EXPECT_EQ(s->materials[0].scattering, Scattering::kMirror);
  EXPECT_EQ(s->materials[0].specular, glm::vec3(0.9f, 0.8f, 0.7f));
  EXPECT_EQ(s->materials[0].reflectance, glm::vec3(0.9f, 0.8f, 0.7f));
  EXPECT_EQ(s->materials[1].scattering, Scattering::kDielectric);
  EXPECT_FLOAT_EQ(s->materials[1].ior, 1.52f);
  EXPECT_NEAR(s->materials[1].reflectance.x, std::pow(0.52 / 2.52, 2.0), 1e-6);
  EXPECT_EQ(s->materials[2].scattering, Scattering::kDiffuse);
  ASSERT_EQ(s->meshes.size(), 3u);
  // The sphere: 20 x 4^2 triangles on radius 0.5 around (1, 2, 3), wound outwards.
  const Mesh& ball = s->meshes[1];
  EXPECT_EQ(ball.triangles.size(), 320u);
  for (const glm::vec3& p : ball.positions) {
    EXPECT_NEAR(glm::length(p - glm::vec3(1, 2, 3)), 0.5f, 1e-5f);
  }
  for (const glm::uvec3& t : ball.triangles) {
    const glm::vec3 c = (ball.positions[t.x] + ball.positions[t.y] + ball.positions[t.z]) / 3.0f;
    const glm::vec3 n = glm::cross(ball.positions[t.y] - ball.positions[t.x],
                                   ball.positions[t.z] - ball.positions[t.x]);
    EXPECT_GT(glm::dot(n, c - glm::vec3(1, 2, 3)), 0.0f);
  }
  EXPECT_EQ(s->meshes[2].triangles.size(), 20u);
  const std::vector<std::string> warnings = diffuseStandInWarnings(*s, "progressive");
  ASSERT_EQ(warnings.size(), 2u);
  EXPECT_NE(warnings[0].find("material 'chrome' is a mirror: --method progressive sees a diffuse "
                             "surface of reflectance (0.9, 0.8, 0.7)"),
            std::string::npos)
      << warnings[0];
  EXPECT_NE(warnings[1].find("glass (ior 1.52)"), std::string::npos) << warnings[1];

  const std::pair<const char*, const char*> bad[] = {
      {R"({"m": {"type": "metal"}})", "materials.m.type: unknown type 'metal'"},
      {R"({"m": {"type": "glass", "ior": 0.5}})", "materials.m.ior: 0.5 is outside [1, 4]"},
      {R"({"m": {"type": "mirror", "ior": 1.5}})", "materials.m.ior: applies to"},
      {R"({"m": {"specular": [1, 1, 1]}})", "materials.m.specular: applies to"},
      {R"({"m": {"type": "mirror", "reflectance": [1, 1, 1]}})", "materials.m.reflectance"},
      {R"({"m": {"type": "glass", "specular": [1, 2, 1]}})", "materials.m.specular"},
      {R"({"m": {"type": "glass", "subsurface": "marble"}})", "materials.m.subsurface"},
  };
  for (const auto& [materials, expected] : bad) {
    const std::string p = dir.write("bad.json", std::string(R"({"materials": )") + materials +
                                                    R"(, "meshes": [{"sphere": 1}]})");
    EXPECT_TRUE(errorNames(loadSceneJson(p), p, expected)) << materials;
  }
  const std::pair<const char*, const char*> bad_meshes[] = {
      {R"([{"sphere": 9}])", "meshes[0].sphere: must be a subdivision level"},
      {R"([{"sphere": -1}])", "meshes[0].sphere"},
      {R"([{"sphere": 1.5}])", "meshes[0].sphere"},
      {R"([{"sphere": 1, "file": "tri.obj"}])", "not both"},
      {R"([{"material": "m"}])", "needs"},
  };
  for (const auto& [meshes, expected] : bad_meshes) {
    const std::string p =
        dir.write("bad.json", std::string(R"({"materials": {"m": {}}, "meshes": )") + meshes + "}");
    EXPECT_TRUE(errorNames(loadSceneJson(p), p, expected)) << meshes;
  }
}

// "materials" as an array keeps its order (the order mesh arrays count materials in, penumbra.h:
// Scene::fromArrays), whatever the names; an object's materials come sorted by name.
TEST(SceneJsonLoad, MaterialsAsAnArrayKeepTheirOrder) {
  TempDir dir;
  dir.write("tri.obj", kTriangleObj);
  const std::string path = dir.write("scene.json", R"({
    "materials": [{"name": "zinc", "reflectance": [0.2, 0.2, 0.2]}, {"emission": [1, 2, 3]},
                  {"name": "amber", "two_sided": false}],
    "meshes": [{"file": "tri.obj", "material": "amber"}]
  })");
  Expected<Scene> s = loadSceneJson(path);
  ASSERT_TRUE(s.ok()) << s.error().describe();
  ASSERT_EQ(s->materials.size(), 3u);
  EXPECT_EQ(s->materials[0].name, "zinc");
  EXPECT_FLOAT_EQ(s->materials[0].reflectance.x, 0.2f);
  EXPECT_EQ(s->materials[1].name, "material 1");
  EXPECT_FLOAT_EQ(s->materials[1].emission.z, 3.0f);
  EXPECT_EQ(s->materials[2].name, "amber");
  EXPECT_EQ(s->meshes[0].material_ids[0], 2u);
  const std::string twice = dir.write("twice.json", R"({
    "materials": [{"name": "a"}, {"name": "a"}], "meshes": [{"file": "tri.obj"}]})");
  EXPECT_TRUE(errorNames(loadSceneJson(twice), twice, "materials[1].name"));
  const std::string bad = dir.write("bad.json", R"({
    "materials": [{"name": "a", "reflectance": [2, 0, 0]}], "meshes": [{"file": "tri.obj"}]})");
  EXPECT_TRUE(errorNames(loadSceneJson(bad), bad, "materials[0].reflectance"));
  const std::string neither = dir.write("neither.json", R"({
    "materials": "grey", "meshes": [{"file": "tri.obj"}]})");
  EXPECT_TRUE(errorNames(loadSceneJson(neither), neither, "materials"));
}

// "environment": a colour or one number for grey, 0 when absent; negative values and values a
// float cannot hold are refused with the key path (JSON itself has no infinities).
TEST(SceneJsonLoad, EnvironmentIsAColourOrOneGreyNumber) {
  TempDir dir;
  dir.write("tri.obj", kTriangleObj);
  const auto scene = [&](const std::string& name, const std::string& env) {
    return dir.write(name, R"({"meshes": [{"file": "tri.obj"}])" + env + "}");
  };
  Expected<Scene> none = loadSceneJson(scene("none.json", ""));
  ASSERT_TRUE(none.ok()) << none.error().describe();
  expectNear(none->environment, glm::vec3(0.0f), 0.0f);
  Expected<Scene> rgb = loadSceneJson(scene("rgb.json", R"(, "environment": [0.1, 0.2, 3])"));
  ASSERT_TRUE(rgb.ok()) << rgb.error().describe();
  expectNear(rgb->environment, glm::vec3(0.1f, 0.2f, 3.0f), 0.0f);
  Expected<Scene> grey = loadSceneJson(scene("grey.json", R"(, "environment": 2)"));
  ASSERT_TRUE(grey.ok()) << grey.error().describe();
  expectNear(grey->environment, glm::vec3(2.0f), 0.0f);

  struct Case {
    const char* name;
    const char* env;
    const char* place;
  };
  const Case cases[] = {
      {"negative.json", R"(, "environment": -1)", "environment: -1 is outside [0, inf)"},
      {"channel.json", R"(, "environment": [1, -2, 0])", "environment[1]: -2 is outside"},
      {"length.json", R"(, "environment": [1, 2])", "environment: must be an array of 3 numbers"},
      {"type.json", R"(, "environment": "sky")", "environment: must be a number or an array"},
      {"float.json", R"(, "environment": [1e39, 0, 0])", "environment: (inf, 0, 0) must be finite"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string path = scene(c.name, c.env);
    EXPECT_TRUE(errorNames(loadSceneJson(path), path, c.place));
  }
}

// The daylight keys are input like the rest: a sky, openings and their glazing out of range, of
// the wrong type or unknown are refused with the key path; the glazing's fall-off is read.
TEST(SceneJsonLoad, DaylightKeysAreCheckedWithTheirPlace) {
  TempDir dir;
  dir.write("tri.obj", kTriangleObj);
  const auto scene = [&](const std::string& name, const std::string& extra) {
    return dir.write(name, R"({"meshes": [{"file": "tri.obj"}])" + extra + "}");
  };
  const std::string opening =
      R"(, "openings": [{"corners": [[0, 3, 0], [1, 3, 0], [1, 3, 1], [0, 3, 1]], "glazing": )";
  Expected<Scene> ok = loadSceneJson(
      scene("ok.json", opening + R"({"transmittance": 0.8, "falloff": "clear_glass"}}])"));
  ASSERT_TRUE(ok.ok()) << ok.error().describe();
  ASSERT_EQ(ok->openings.size(), 1u);
  EXPECT_EQ(ok->openings[0].falloff, GlazingFalloff::kClearGlass);
  EXPECT_NEAR(ok->openings[0].transmittanceAt(1.0), 0.8, 1e-12);
  EXPECT_NEAR(ok->openings[0].transmittanceAt(0.5), 0.8 * clearGlassTransmittance(0.5) / 0.87881,
              1e-5);
  struct Case {
    const char* name;
    std::string extra;
    const char* place;
  };
  const Case cases[] = {
      {"falloff.json", opening + R"({"falloff": "frosted"}}])",
       "openings[0].glazing.falloff: 'frosted' is not fresnel or clear_glass"},
      {"tau.json", opening + R"({"transmittance": 1.5}}])", "openings[0].glazing.transmittance"},
      {"ior.json", opening + R"({"ior": 0.5}}])", "openings[0].glazing.ior"},
      {"key.json", opening + R"({"tint": 0.5}}])", "openings[0].glazing.tint: unknown key"},
      {"sky.json", R"(, "sky": {"type": 17, "horizontal_illuminance": 10000})", "sky.type"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string path = scene(c.name, c.extra);
    EXPECT_TRUE(errorNames(loadSceneJson(path), path, c.place));
  }
}

// Numbers a file may carry that overflow single precision, or that would overflow it in the
// methods' sums (a light a million scene radii away: its squared distance), are refused with the
// file and the light, before any method runs: they crashed or made NaN and inf images.
TEST(SceneJsonLoad, LightsAndEmissionThatOverflowAreRefused) {
  TempDir dir;
  dir.write("tri.obj", kTriangleObj);
  struct Case {
    const char* name;
    const char* extra;
    const char* message;
  };
  const Case cases[] = {
      {"far.json",
       R"(, "lights": [{"type": "point", "position": [1e39, 0, 0], "intensity": [1, 1, 1]}])",
       "light 0 (point): position (inf, 0, 0) must be finite and within"},
      {"distant.json",
       R"(, "lights": [{"type": "point", "position": [0, 1e12, 0], "intensity": [1, 1, 1]}])",
       "light 0 (point): position (0, 1e+12, 0) must be finite and within"},
      {"bright.json",
       R"(, "lights": [{"type": "point", "position": [0, 1, 0], "intensity": [1e300, 1, 1]}])",
       "light 0 (point): intensity (inf, 1, 1) must be finite, non-negative and at most"},
      {"brighter.json",
       R"(, "lights": [{"type": "directional", "direction": [0, -1, 0],
                        "irradiance": [1e20, 1, 1]}])",
       "light 0 (directional): irradiance (1e+20, 1, 1) must be finite"},
      {"glow.json", R"(, "materials": {"glow": {"emission": [1e20, 0, 0]}})",
       "emission (1e+20, 0, 0) must be finite, non-negative and at most 1e15"},
  };
  // A luminaire array spacing of 1e300 puts its luminaires at -inf and inf.
  const std::string ldt = test::dataPath("photometry/ledvance_biolux_dn150.ldt");
  const std::string array = R"(, "lights": [{"type": "luminaire", "file": ")" + ldt +
                            R"(", "position": [0, 1, 0],
                           "array": {"count": [2, 2], "spacing": [1e300, 1]}}])";
  const std::string array_path =
      dir.write("array.json", R"({"meshes": [{"file": "tri.obj"}])" + array + "}");
  EXPECT_TRUE(errorNames(loadSceneJson(array_path), array_path,
                         "light 0 (luminaire): position (-inf, 1, -0.5) must be finite"));
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string material =
        std::string(c.name) == "glow.json" ? R"(, "material": "glow")" : "";
    const std::string path =
        dir.write(c.name, R"({"meshes": [{"file": "tri.obj")" + material + "}]" + c.extra + "}");
    EXPECT_TRUE(errorNames(loadSceneJson(path), path, c.message));
  }
}

TEST(SceneJsonLoad, TransformsLightsCameraSettings) {
  TempDir dir;
  dir.write("tri.obj", kTriangleObj);
  dir.write("m.mtl", "newmtl glow\nKd 0.2 0.2 0.2\nKe 1 2 3\n");
  dir.write("lit.obj", "mtllib m.mtl\nusemtl glow\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  const std::string path = dir.write("scene.json", R"({
    // comments are allowed
    "materials": {"grey": {"reflectance": [0.5, 0.5, 0.5]}},
    "meshes": [
      {"file": "tri.obj", "material": "grey",
       "transform": {"scale": [2, 1, 1], "rotate_deg": [0, 0, 90], "translate": [10, 0, 0]}},
      {"file": "tri.obj", "transform": {"rotate_deg": [90, 90, 0]}},
      {"file": "tri.obj", "transform": {"scale": [-1, 1, 1]}, "name": "mirror"},
      {"file": "tri.obj", "transform": {"matrix": [1,0,0,5, 0,1,0,0, 0,0,1,0, 0,0,0,1]}},
      {"file": "tri.obj", "transform": {"scale": [2, 1, 1]}},
      {"file": "lit.obj"},
      {"file": "lit.obj", "material": "grey"}
    ],
    "lights": [
      {"type": "point", "position": [0, 1, 0], "intensity": [1, 2, 3]},
      {"type": "spot", "position": [0, 2, 0], "direction": [0, -2, 0], "intensity": [4, 4, 4],
       "inner_angle_deg": 10, "outer_angle_deg": 30},
      {"type": "directional", "direction": [0, 0, -1], "irradiance": [5, 6, 7]}
    ],
    "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_deg": 45},
    "settings": {"pathtrace": {"spp": 64}, "matrix": {"solver": "gauss-seidel"}}
  })");
  Expected<Scene> s = loadSceneJson(path);
  ASSERT_TRUE(s.ok()) << s.error().describe();
  ASSERT_EQ(s->meshes.size(), 7u);
  // Scale, then rotate, then translate: (1,0,0) -> (2,0,0) -> (0,2,0) -> (10,2,0).
  const Mesh& a = s->meshes[0];
  expectNear(a.positions[1], {10, 2, 0});
  expectNear(a.positions[2], {9, 0, 0});
  EXPECT_EQ(s->materials[a.material_ids[0]].name, "grey");
  // Rotations apply X, then Y: (0,1,0) -> (0,0,1) -> (1,0,0).
  expectNear(s->meshes[1].positions[2], {1, 0, 0});
  // Mirroring flips the winding: the triangle still faces +z.
  const Mesh& m = s->meshes[2];
  EXPECT_EQ(m.name, "mirror");
  const glm::uvec3 t = m.triangles[0];
  EXPECT_GT(glm::cross(m.positions[t.y] - m.positions[t.x], m.positions[t.z] - m.positions[t.x]).z,
            0.0f);
  expectNear(m.normals[0], {-0.70710678f, 0.70710678f, 0});
  // Row-major matrix with the translation in the last column.
  expectNear(s->meshes[3].positions[1], {6, 0, 0});
  // Normals by the inverse transpose: scale x by 2 turns (1,1,0) into (1,2,0) / sqrt(5).
  expectNear(s->meshes[4].normals[0], glm::vec3(1, 2, 0) / std::sqrt(5.0f));
  // Without "material" the file's own materials are used; with it they are replaced.
  const Material& glow = s->materials[s->meshes[5].material_ids[0]];
  EXPECT_EQ(glow.name, "glow");
  expectNear(glow.emission, {1, 2, 3});
  EXPECT_EQ(s->materials[s->meshes[6].material_ids[0]].name, "grey");

  ASSERT_EQ(s->lights.size(), 3u);
  const PointLight& p = std::get<PointLight>(s->lights[0]);
  expectNear(p.intensity, {1, 2, 3});
  const SpotLight& spot = std::get<SpotLight>(s->lights[1]);
  expectNear(spot.direction, {0, -1, 0});
  EXPECT_NEAR(spot.inner_angle, 10.0 * std::numbers::pi / 180.0, 1e-6);
  EXPECT_NEAR(spot.outer_angle, 30.0 * std::numbers::pi / 180.0, 1e-6);
  const DirectionalLight& d = std::get<DirectionalLight>(s->lights[2]);
  expectNear(d.irradiance, {5, 6, 7});
  ASSERT_TRUE(s->camera.has_value());
  EXPECT_NEAR(s->camera->vertical_fov, std::numbers::pi / 4.0, 1e-6);
  expectNear(s->camera->up, {0, 1, 0});
  EXPECT_EQ(s->settings["pathtrace"]["spp"], 64);
  EXPECT_EQ(s->settings["matrix"]["solver"], "gauss-seidel");
}

using test::errorNames;

TEST(SceneJsonLoad, StrictErrorsNameTheKeyPath) {
  TempDir dir;
  dir.write("tri.obj", kTriangleObj);
  const std::string mesh = R"({"file": "tri.obj"})";
  const std::string ldt = test::dataPath("photometry/ledvance_biolux_dn150.ldt");
  const std::string bega = test::dataPath("photometry/bega_50988_lm63_1995.ies");
  struct Case {
    const char* name;
    std::string text;
    const char* place;
  };
  const Case cases[] = {
      {"typo.json",
       R"({"meshes": [)" + mesh + "," + mesh + R"(, {"file": "tri.obj", "transfrom": {}}]})",
       "meshes[2].transfrom: unknown key"},
      {"top.json", R"({"mesh": []})", "mesh: unknown key"},
      {"type.json", R"({"meshes": [{"file": 3}]})", "meshes[0].file: must be a string"},
      {"length.json",
       R"({"meshes": [)" + mesh + R"(], "camera": {"position": [0, 1], "look_at": [0, 0, 0]}})",
       "camera.position: must be an array of 3 numbers"},
      {"scale.json", R"({"meshes": [{"file": "tri.obj", "transform": {"scale": [1, 2]}}]})",
       "meshes[0].transform.scale"},
      {"matrix.json", R"({"meshes": [{"file": "tri.obj", "transform": {"matrix": [1, 0, 0]}}]})",
       "meshes[0].transform.matrix"},
      {"singular.json", R"({"meshes": [{"file": "tri.obj", "transform": {"scale": 0}}]})",
       "meshes[0].transform: the transform is singular"},
      {"undefined.json", R"({"meshes": [{"file": "tri.obj", "material": "gold"}]})",
       "meshes[0].material: material 'gold' is not defined"},
      {"refl.json",
       R"({"materials": {"w": {"reflectance": [0.5, 1.5, 0.5]}}, "meshes": [)" + mesh + "]}",
       "materials.w.reflectance[1]"},
      {"subsurface.json", R"({"materials": {"skin": {"subsurface": {"preset": "Skin1"}}}})",
       "materials.skin.subsurface.preset: unknown measured material 'Skin1' (known: apple"},
      {"normalmap.json", R"({"materials": {"w": {"normal_map": "n.png"}}})",
       "materials.w.normal_map: 'n.png' does not exist"},
      {"normalscale.json", R"({"materials": {"w": {"normal_scale": -1}}})",
       "materials.w.normal_scale: -1 is outside [0, 100]"},
      {"luminaire.json",
       R"({"lights": [{"type": "luminaire", "file": "a.ldt", "position": [0, 2, 0]}]})",
       "lights[0].file: 'a.ldt' does not exist"},
      {"lumpos.json", R"({"lights": [{"type": "luminaire", "file": "a.ldt"}]})",
       "lights[0].position: missing"},
      {"dimming.json",
       R"({"lights": [{"type": "luminaire", "file": ")" + ldt +
           R"(", "position": [0, 2, 0], "dimming": 1.5}]})",
       "lights[0].dimming: 1.5 is outside [0, 1]"},
      {"lamps.json",
       R"({"lights": [{"type": "luminaire", "file": ")" + bega +
           R"(", "position": [0, 2, 0], "lamps": 2}]})",
       "lights[0].lamps:"},
      {"lumarray.json",
       R"({"lights": [{"type": "luminaire", "file": ")" + ldt +
           R"(", "position": [0, 2, 0], "array": {"count": [2, 0.5], "spacing": [1, 1]}}]})",
       "lights[0].array.count[1]: 0.5 is not a whole number"},
      {"lumaim.json",
       R"({"lights": [{"type": "luminaire", "file": ")" + ldt +
           R"(", "position": [0, 2, 0], "aim": [0, 0, 0]}]})",
       "lights[0].aim"},
      {"lightkey.json",
       R"({"lights": [{"type": "point", "position": [0, 0, 0], "intensity": [1, 1, 1], "power": 3}]})",
       "lights[0].power: unknown key"},
      {"spot.json",
       R"({"lights": [{"type": "spot", "position": [0, 0, 0], "direction": [0, 0, 0],
           "intensity": [1, 1, 1]}]})",
       "lights[0].direction"},
      {"settings.json", R"({"settings": [1, 2]})", "settings: must be an object"},
      {"nomesh.json", R"({"meshes": [{"file": "gone.obj"}]})", "meshes[0].file: 'gone.obj'"},
      {"ext.json", R"({"meshes": [{"file": "x.stl"}]})", "meshes[0].file"},
      {"empty-scene.json", R"({})", "no triangles"},
      {"array.json", R"([1, 2])", "top level must be an object"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string path = dir.write(c.name, c.text);
    EXPECT_TRUE(errorNames(loadSceneJson(path), path, c.place));
  }
}

TEST(SceneJsonLoad, LuminairesWithTheirFrameScaleAndArrays) {
  TempDir dir;
  dir.write("tri.obj", kTriangleObj);
  const std::string ldt = test::dataPath("photometry/ledvance_biolux_dn150.ldt");
  const std::string path =
      dir.write("lum.json",
                R"({"meshes": [{"file": "tri.obj"}], "lights": [{"type": "luminaire", "file": ")" +
                    ldt + R"(", "position": [1, 3, 2], "aim": [1, 0, 0], "rotation_deg": 90,
      "dimming": 0.5, "flux_lm": 3000, "colour": [1, 0.5, 1],
      "array": {"count": [3, 2], "spacing": [1.5, 2]}}]})");
  Expected<Scene> s = loadSceneJson(path);
  ASSERT_TRUE(s.ok()) << s.error().describe();
  ASSERT_EQ(s->lights.size(), 6u);
  const LuminaireLight& first = std::get<LuminaireLight>(s->lights[0]);
  const LuminaireLight& last = std::get<LuminaireLight>(s->lights[5]);
  // The array is centred on the position, along world x and z.
  EXPECT_NEAR(glm::length(first.position - glm::vec3(-0.5f, 3.0f, 1.0f)), 0.0f, 1e-6f);
  EXPECT_NEAR(glm::length(last.position - glm::vec3(2.5f, 3.0f, 3.0f)), 0.0f, 1e-6f);
  // Aimed along +x: C0 from +z (x is the aim), turned 90 degrees towards C90 = c0 x aim.
  EXPECT_NEAR(glm::length(first.nadir - glm::vec3(1, 0, 0)), 0.0f, 1e-6f);
  EXPECT_NEAR(glm::length(first.c0 - glm::cross(glm::vec3(0, 0, 1), glm::vec3(1, 0, 0))), 0.0f,
              1e-6f);
  // 3000 lm dimmed to half is 1500 lm (over 683 lm/W), tinted per channel.
  const glm::dvec3 power = luminairePower(first) * kLumensPerWatt;
  EXPECT_NEAR(power.x, 1500.0, 1e-3);
  EXPECT_NEAR(power.y, 750.0, 1e-3);
  EXPECT_EQ(first.distribution, last.distribution);  // one texture for the array
}

TEST(SceneJsonLoad, SubsurfaceMaterialsInEveryForm) {
  TempDir dir;
  dir.write("tri.obj", kTriangleObj);
  const std::string path = dir.write("sss.json", R"({
    "materials": {
      "a": {"subsurface": "marble"},
      "b": {"subsurface": {"preset": "skin1", "eta": 1.4, "scale": 2}},
      "c": {"subsurface": {"sigma_s_prime": [1, 2, 3], "sigma_a": 0.01}},
      "d": {"subsurface": {"albedo": [0.8, 0.5, 0.2], "distance_mm": [3, 2, 1]}},
      "e": {"reflectance": [0.1, 0.1, 0.1], "subsurface": "ketchup"}
    },
    "meshes": [{"file": "tri.obj", "material": "a"}]
  })");
  Expected<Scene> s = loadSceneJson(path);
  ASSERT_TRUE(s.ok()) << s.error().describe();
  auto material = [&](const char* name) -> const Material& {
    for (const Material& m : s->materials) {
      if (m.name == name) return m;
    }
    ADD_FAILURE() << name;
    return s->materials[0];
  };
  // Jensen et al. 2001's marble, per millimetre -> per metre.
  const Subsurface& marble = *material("a").subsurface;
  EXPECT_EQ(marble.preset, "marble");
  EXPECT_NEAR(marble.sigma_s_prime.x, 2190.0, 1e-9);
  EXPECT_NEAR(marble.sigma_a.z, 7.1, 1e-9);
  EXPECT_EQ(marble.eta, 1.3);
  // Its stand-in reflectance for the other methods: (1 - F_dr,ext)^2 R_d, between the dipole's
  // R_d and 80% of it.
  const glm::dvec3 rd = Dipole(marble.sigma_s_prime, marble.sigma_a, 1.3).totalReflectance();
  EXPECT_LT(material("a").reflectance.x, rd.x);
  EXPECT_GT(material("a").reflectance.x, 0.8 * rd.x);
  const Subsurface& skin = *material("b").subsurface;
  EXPECT_EQ(skin.eta, 1.4);
  EXPECT_NEAR(skin.sigma_a.x, 2 * 32.0, 1e-9);
  EXPECT_NEAR(material("c").subsurface->sigma_s_prime.z, 3000.0, 1e-9);
  EXPECT_NEAR(material("c").subsurface->sigma_a.y, 10.0, 1e-9);
  // The albedo form inverts the dipole: the medium shows that R_d and diffuses that far.
  const Subsurface& wax = *material("d").subsurface;
  const Dipole dw(wax.sigma_s_prime, wax.sigma_a, wax.eta);
  const double want_rd[3] = {0.8, 0.5, 0.2}, want_d[3] = {3e-3, 2e-3, 1e-3};
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(dw.channel[c].totalReflectance(), want_rd[c], 1e-9);
    EXPECT_NEAR(1.0 / dw.channel[c].sigma_tr, want_d[c], 1e-12);
  }
  // A reflectance given with the medium stays.
  EXPECT_EQ(material("e").reflectance, glm::vec3(0.1f));

  struct Case {
    const char* block;
    const char* place;
  };
  const Case bad[] = {
      {R"({"sigma_s_prime": [1, -1, 1], "sigma_a": 0.1})",
       "materials.m.subsurface: sigma_s' -1000"},
      {R"({"sigma_s_prime": 1, "sigma_a": [0.1, NaN, 0.1]})", "line"},  // not JSON: a syntax error
      {R"({"sigma_s_prime": 0, "sigma_a": 0})", "materials.m.subsurface: a channel with sigma_s'"},
      {R"({"preset": "marble", "eta": 0.9})", "materials.m.subsurface: eta 0.9 is outside"},
      {R"({"sigma_s_prime": 1})", "materials.m.subsurface: needs sigma_a too"},
      {R"({"preset": "marble", "sigma_s_prime": 1, "sigma_a": 1})", "give exactly one of"},
      {R"({"albedo": 1.2, "distance_mm": 1})", "albedo 1.2 is outside [0, 1)"},
      {R"({"albedo": 0.5, "distance_mm": 0})", "distance 0 is not a positive number"},
      {R"({"preset": "marble", "scale": -1})", "materials.m.subsurface.scale: must be a positive"},
      {R"({"preset": "marble", "colour": 1})", "materials.m.subsurface.colour: unknown key"},
      {R"(3)", "materials.m.subsurface: must be a preset name or an object"},
  };
  for (const Case& c : bad) {
    SCOPED_TRACE(c.block);
    const std::string p =
        dir.write("bad.json", std::string(R"({"materials": {"m": {"subsurface": )") + c.block +
                                  R"(}}, "meshes": [{"file": "tri.obj"}]})");
    EXPECT_TRUE(errorNames(loadSceneJson(p), p, c.place));
  }
}

TEST(SceneJsonLoad, ParseErrorsGiveLineAndColumn) {
  TempDir dir;
  // Line 3 lacks the comma after its value; the parser stops at the end of the next key, the
  // unexpected token: line 4, column 10.
  const std::string path =
      dir.write("broken.json", "{\n  \"materials\": {},\n  \"meshes\": []\n  \"lights\": []\n}\n");
  Expected<Scene> s = loadSceneJson(path);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().file, path);
  EXPECT_EQ(s.error().place, "line 4, column 10") << s.error().describe();
  EXPECT_EQ(s.error().message.find("[json.exception"), std::string::npos);
  // Truncated: the end of the input.
  const std::string cut = dir.write("cut.json", "{\n  \"meshes\": [\n");
  Expected<Scene> c = loadSceneJson(cut);
  ASSERT_FALSE(c.ok());
  EXPECT_TRUE(errorNames(c, cut, "line 3, column 1"));
  const std::string empty = dir.write("empty.json", "");
  EXPECT_TRUE(errorNames(loadSceneJson(empty), empty, "line 1, column 1"));
}

TEST(SceneJsonLoad, DeepNestingIsRefusedWithThePlace) {
  // A "settings" value nested 300,000 deep overflows a recursive parser or copy; it is refused
  // where it passes 256 levels, and brackets inside strings and comments do not count.
  TempDir dir;
  const std::string deep = std::string(300000, '[') + std::string(300000, ']');
  const std::string path = dir.write("deep.json", "{\n  \"settings\": " + deep + "\n}\n");
  EXPECT_TRUE(errorNames(loadSceneJson(path), path, "line 2, column 270: JSON nested more"));
  const std::string quoted =
      dir.write("quoted.json", "{\"settings\": {\"x\": \"" + std::string(1000, '[') +
                                   "\\\"\"}, // " + std::string(1000, '{') + "\n /* " +
                                   std::string(1000, '[') + " */ \"meshes\": []}");
  Expected<Scene> s = loadSceneJson(quoted);
  ASSERT_FALSE(s.ok());  // no meshes, but parsed: the error is about the content
  EXPECT_EQ(s.error().message.find("nested"), std::string::npos) << s.error().describe();
}

TEST(SceneJsonLoad, MeshFileErrorsNameTheMeshFile) {
  TempDir dir;
  const std::string obj = dir.write("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n");
  const std::string path = dir.write("scene.json", R"({"meshes": [{"file": "bad.obj"}]})");
  Expected<Scene> s = loadSceneJson(path);
  EXPECT_TRUE(errorNames(s, obj, "line 4"));
}

TEST(SceneJsonLoad, DispatchersChooseBuiltinOrFile) {
  Expected<Scene> cornell = loadScene("cornell");
  ASSERT_TRUE(cornell.ok()) << cornell.error().describe();
  EXPECT_EQ(cornell->source, "builtin:cornell");
  Expected<Scene> furnace = loadScene("furnace");
  ASSERT_TRUE(furnace.ok()) << furnace.error().describe();
  Expected<Scene> unknown = loadScene("no-such-scene");
  ASSERT_FALSE(unknown.ok());
  EXPECT_NE(unknown.error().describe().find("no-such-scene"), std::string::npos);
  EXPECT_EQ(unknown.error().describe(), builtinScene("no-such-scene").error().describe());
  Expected<Scene> missing = loadScene("missing.obj");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().describe().find("missing.obj"), std::string::npos);
  TempDir dir;
  const std::string stl = dir.write("a.stl", "solid a\n");
  Expected<Scene> other = loadSceneFile(stl);
  ASSERT_FALSE(other.ok());
  EXPECT_NE(other.error().describe().find(".stl"), std::string::npos);
  Expected<Scene> ply = loadScene(dataPath("teapot.ply"));
  ASSERT_TRUE(ply.ok()) << ply.error().describe();
  EXPECT_EQ(ply->triangleCount(), 2256u);
  Expected<Scene> obj = loadSceneFile(dataPath("cornell-box/floor.obj"));
  ASSERT_TRUE(obj.ok()) << obj.error().describe();
}

}  // namespace
}  // namespace penumbra
