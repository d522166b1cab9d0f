// glTF loading: a small file written here, as .gltf with a base64 data-URI buffer and as .glb,
// with a node hierarchy (translation, rotation, scale), an emissive material with
// KHR_materials_emissive_strength, KHR_lights_punctual point and spot lights and a camera; and
// malformed files whose errors name the file and the accessor, vertex or extension.
#include "penumbra/core/file_util.h"
#include "penumbra/geometry/shading_normals.h"
#include "penumbra/io/image_io.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/kernels/dipole.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

namespace penumbra {
namespace {

using nlohmann::json;
using test::base64;
using test::TempDir;

template <typename T>
void append(std::string& buf, std::initializer_list<T> values) {
  for (T v : values) buf.append(reinterpret_cast<const char*>(&v), sizeof(T));
}

// A unit quad in the XY plane facing +z: positions (48 bytes), normals (48), ushort indices (12).
struct TestGltf {
  json doc;
  std::string bin;
};

TestGltf makeTestGltf() {
  TestGltf g;
  append<float>(g.bin, {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0});
  append<float>(g.bin, {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1});
  append<uint16_t>(g.bin, {0, 1, 2, 0, 2, 3});
  const double s = std::sqrt(0.5);
  g.doc = json::parse(R"({
    "asset": {"version": "2.0"},
    "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength"],
    "scene": 0,
    "scenes": [{"nodes": [0]}],
    "nodes": [
      {"name": "root", "translation": [1, 2, 3], "children": [1, 2, 3, 4]},
      {"name": "quad", "mesh": 0, "scale": [2, 2, 2]},
      {"translation": [0, 5, 0], "extensions": {"KHR_lights_punctual": {"light": 0}}},
      {"translation": [0, 3, 0], "extensions": {"KHR_lights_punctual": {"light": 1}}},
      {"translation": [0, 0, 10], "camera": 0}
    ],
    "meshes": [{"name": "quadmesh", "primitives": [
      {"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0}]}],
    "materials": [{"name": "lamp",
      "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.25, 0.125, 1]},
      "emissiveFactor": [1, 0.5, 0.25],
      "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4}}}],
    "extensions": {"KHR_lights_punctual": {"lights": [
      {"type": "point", "color": [1, 0.5, 0.25], "intensity": 683},
      {"type": "spot", "intensity": 1366, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}}
    ]}},
    "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.01}}],
    "buffers": [{"byteLength": 108}],
    "bufferViews": [
      {"buffer": 0, "byteOffset": 0, "byteLength": 48},
      {"buffer": 0, "byteOffset": 48, "byteLength": 48},
      {"buffer": 0, "byteOffset": 96, "byteLength": 12}
    ],
    "accessors": [
      {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
       "min": [0, 0, 0], "max": [1, 1, 0]},
      {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
      {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}
    ]
  })");
  // The quad node turns 90 degrees about +y: local +x goes to world -z, local +z to world +x.
  g.doc["nodes"][1]["rotation"] = {0.0, s, 0.0, s};
  // The spot node turns -90 degrees about +x, so its local -z points down (world -y).
  g.doc["nodes"][3]["rotation"] = {-s, 0.0, 0.0, s};
  return g;
}

std::string writeGltf(const TempDir& dir, const std::string& name, TestGltf g) {
  g.doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64(g.bin);
  return dir.write(name, g.doc.dump(2));
}

std::string writeGlb(const TempDir& dir, const std::string& name, const TestGltf& g) {
  return dir.write(name, test::glbBytes(g.doc, g.bin));
}

void expectNear(const glm::vec3& a, const glm::vec3& b, float tol = 1e-5f) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}

void checkTestScene(const Scene& s) {
  ASSERT_EQ(s.meshes.size(), 1u);
  const Mesh& m = s.meshes[0];
  EXPECT_EQ(m.name, "quad");
  ASSERT_EQ(m.positions.size(), 4u);
  ASSERT_EQ(m.triangles.size(), 2u);
  EXPECT_EQ(m.triangles[0], glm::uvec3(0, 1, 2));
  EXPECT_EQ(m.triangles[1], glm::uvec3(0, 2, 3));
  // world = T(1,2,3) R_y(90) S(2): (1,0,0) -> (1,2,1); (0,1,0) -> (1,4,3); (1,1,0) -> (1,4,1).
  expectNear(m.positions[0], {1, 2, 3});
  expectNear(m.positions[1], {1, 2, 1});
  expectNear(m.positions[2], {1, 4, 1});
  expectNear(m.positions[3], {1, 4, 3});
  ASSERT_EQ(m.normals.size(), 4u);
  expectNear(m.normals[0], {1, 0, 0});
  // The geometric normal of the counter-clockwise triangle agrees with the shading normal.
  const glm::vec3 g =
      glm::normalize(glm::cross(m.positions[1] - m.positions[0], m.positions[2] - m.positions[0]));
  expectNear(g, {1, 0, 0});

  ASSERT_EQ(s.materials.size(), 1u);
  const Material& mat = s.materials[m.material_ids[0]];
  EXPECT_EQ(mat.name, "lamp");
  expectNear(mat.reflectance, {0.5f, 0.25f, 0.125f});
  expectNear(mat.emission, {4.0f, 2.0f, 1.0f});  // emissiveFactor x emissiveStrength 4

  ASSERT_EQ(s.lights.size(), 2u);
  const PointLight* point = std::get_if<PointLight>(&s.lights[0]);
  ASSERT_NE(point, nullptr);
  expectNear(point->position, {1, 7, 3});
  expectNear(point->intensity, {1.0f, 0.5f, 0.25f});  // 683 cd / 683 lm/W x colour
  const SpotLight* spot = std::get_if<SpotLight>(&s.lights[1]);
  ASSERT_NE(spot, nullptr);
  expectNear(spot->position, {1, 5, 3});
  expectNear(spot->direction, {0, -1, 0});
  expectNear(spot->intensity, {2, 2, 2});  // 1366 cd / 683
  EXPECT_FLOAT_EQ(spot->inner_angle, 0.2f);
  EXPECT_FLOAT_EQ(spot->outer_angle, 0.5f);

  ASSERT_TRUE(s.camera.has_value());
  expectNear(s.camera->position, {1, 2, 13});
  expectNear(s.camera->look_at, {1, 2, 12});
  expectNear(s.camera->up, {0, 1, 0});
  EXPECT_FLOAT_EQ(s.camera->vertical_fov, 0.8f);
}

TEST(GltfLoad, EmbeddedBufferGltf) {
  TempDir dir;
  const std::string path = writeGltf(dir, "quad.gltf", makeTestGltf());
  Expected<Scene> s = loadGltf(path);
  ASSERT_TRUE(s.ok()) << s.error().describe();
  checkTestScene(*s);
  EXPECT_TRUE(s->warnings.empty()) << s->warnings[0];
}

TEST(GltfLoad, DoubleSidedDecidesTwoSidedness) {
  // glTF's default is one-sided (doubleSided false); Blender writes true.
  TempDir dir;
  Expected<Scene> one = loadGltf(writeGltf(dir, "one.gltf", makeTestGltf()));
  ASSERT_TRUE(one.ok());
  EXPECT_FALSE(one->materials[0].two_sided);
  TestGltf g = makeTestGltf();
  g.doc["materials"][0]["doubleSided"] = true;
  Expected<Scene> two = loadGltf(writeGltf(dir, "two.gltf", g));
  ASSERT_TRUE(two.ok());
  EXPECT_TRUE(two->materials[0].two_sided);
}

TEST(GltfLoad, TranslucentMaterialsFromPenumbrasExtensionAndFromKhrVolume) {
  TempDir dir;
  TestGltf g = makeTestGltf();
  g.doc["materials"][0]["extensions"]["PENUMBRA_materials_subsurface"] =
      json::parse(R"({"preset": "marble", "eta": 1.5})");
  g.doc["extensionsRequired"] = json::array({"PENUMBRA_materials_subsurface"});
  Expected<Scene> own = loadGltf(writeGltf(dir, "own.gltf", g));
  ASSERT_TRUE(own.ok()) << own.error().describe();
  ASSERT_TRUE(own->materials[0].subsurface.has_value());
  EXPECT_EQ(own->materials[0].subsurface->preset, "marble");
  EXPECT_EQ(own->materials[0].subsurface->eta, 1.5);
  // The base colour gives way to the medium's Lambertian stand-in.
  EXPECT_GT(own->materials[0].reflectance.x, 0.6f);  // not the base colour 0.5

  // KHR_materials_volume + transmission: base colour as albedo, distance x colour as the
  // diffusion length (metres), KHR_materials_ior as eta.
  g = makeTestGltf();
  g.doc["materials"][0]["extensions"] = json::parse(R"({
    "KHR_materials_transmission": {"transmissionFactor": 1},
    "KHR_materials_volume": {"attenuationDistance": 0.01, "attenuationColor": [1, 0.5, 0.25]},
    "KHR_materials_ior": {"ior": 1.4}})");
  Expected<Scene> khr = loadGltf(writeGltf(dir, "khr.gltf", g));
  ASSERT_TRUE(khr.ok()) << khr.error().describe();
  const std::optional<Subsurface>& m = khr->materials[0].subsurface;
  ASSERT_TRUE(m.has_value());
  EXPECT_EQ(m->eta, 1.4);
  const Dipole d(m->sigma_s_prime, m->sigma_a, m->eta);
  EXPECT_NEAR(d.channel[0].totalReflectance(), 0.5, 1e-9);  // baseColorFactor 0.5 0.25 0.125
  EXPECT_NEAR(d.channel[2].totalReflectance(), 0.125, 1e-9);
  EXPECT_NEAR(1.0 / d.channel[1].sigma_tr, 0.005, 1e-12);
  ASSERT_FALSE(khr->warnings.empty());
  EXPECT_NE(khr->warnings.back().find("read as a scattering medium"), std::string::npos);

  // A clear volume is glass (GltfLoad.TransmissionIsGlassAndSmoothMetalIsAMirror); a bad
  // medium names its place.
  g.doc["materials"][0]["extensions"]["KHR_materials_volume"] = json::object();
  Expected<Scene> clear = loadGltf(writeGltf(dir, "clear.gltf", g));
  ASSERT_TRUE(clear.ok()) << clear.error().describe();
  EXPECT_FALSE(clear->materials[0].subsurface.has_value());
  EXPECT_EQ(clear->materials[0].scattering, Scattering::kDielectric);
  EXPECT_FLOAT_EQ(clear->materials[0].ior, 1.4f);
  g = makeTestGltf();
  g.doc["materials"][0]["extensions"]["PENUMBRA_materials_subsurface"] =
      json::parse(R"({"sigma_s_prime": 1, "sigma_a": -1})");
  const std::string bad = writeGltf(dir, "bad.gltf", g);
  EXPECT_TRUE(test::errorNames(
      loadGltf(bad), bad, "material 0.extensions.PENUMBRA_materials_subsurface: sigma_a -1000"));
}

// KHR_materials_transmission (with KHR_materials_ior, default 1.5) is smooth glass filtered by
// the base colour; metallic 1 with roughness 0 is a mirror of the base colour; anything rougher
// stays diffuse. The radiosity methods' stand-in reflectance comes with them (scene/scene.h).
TEST(GltfLoad, TransmissionIsGlassAndSmoothMetalIsAMirror) {
  TempDir dir;
  TestGltf g = makeTestGltf();
  g.doc["materials"][0]["extensions"] = json::parse(R"({
    "KHR_materials_transmission": {"transmissionFactor": 1},
    "KHR_materials_ior": {"ior": 1.7}})");
  Expected<Scene> glass = loadGltf(writeGltf(dir, "glass.gltf", g));
  ASSERT_TRUE(glass.ok()) << glass.error().describe();
  const Material& m = glass->materials[0];
  EXPECT_EQ(m.scattering, Scattering::kDielectric);
  EXPECT_FLOAT_EQ(m.ior, 1.7f);
  EXPECT_EQ(m.specular, glm::vec3(0.5f, 0.25f, 0.125f));
  const float r0 = (1.7f - 1.0f) / (1.7f + 1.0f);
  EXPECT_FLOAT_EQ(m.reflectance.x, r0 * r0);
  EXPECT_EQ(m.emission, glm::vec3(1.0f, 0.5f, 0.25f));  // emission is kept

  g.doc["materials"][0]["extensions"] = json::parse(R"({
    "KHR_materials_transmission": {"transmissionFactor": 0.5}})");
  Expected<Scene> half = loadGltf(writeGltf(dir, "half.gltf", g));
  ASSERT_TRUE(half.ok()) << half.error().describe();
  EXPECT_EQ(half->materials[0].scattering, Scattering::kDielectric);
  EXPECT_FLOAT_EQ(half->materials[0].ior, 1.5f);
  ASSERT_FALSE(half->warnings.empty());
  EXPECT_NE(half->warnings.back().find("transmissionFactor 0.5 read as 1"), std::string::npos);

  g.doc["materials"][0]["extensions"] = json::parse(R"({
    "KHR_materials_transmission": {"transmissionFactor": 0}})");
  Expected<Scene> none = loadGltf(writeGltf(dir, "none.gltf", g));
  ASSERT_TRUE(none.ok());
  EXPECT_EQ(none->materials[0].scattering, Scattering::kDiffuse);

  g = makeTestGltf();
  g.doc["materials"][0]["pbrMetallicRoughness"]["metallicFactor"] = 1.0;
  g.doc["materials"][0]["pbrMetallicRoughness"]["roughnessFactor"] = 0.0;
  Expected<Scene> chrome = loadGltf(writeGltf(dir, "chrome.gltf", g));
  ASSERT_TRUE(chrome.ok()) << chrome.error().describe();
  EXPECT_EQ(chrome->materials[0].scattering, Scattering::kMirror);
  EXPECT_EQ(chrome->materials[0].specular, glm::vec3(0.5f, 0.25f, 0.125f));
  EXPECT_EQ(chrome->materials[0].reflectance, glm::vec3(0.5f, 0.25f, 0.125f));
  g.doc["materials"][0]["pbrMetallicRoughness"]["roughnessFactor"] = 0.2;
  Expected<Scene> rough = loadGltf(writeGltf(dir, "rough.gltf", g));
  ASSERT_TRUE(rough.ok());
  EXPECT_EQ(rough->materials[0].scattering, Scattering::kDiffuse);

  g = makeTestGltf();
  g.doc["materials"][0]["extensions"] = json::parse(R"({
    "KHR_materials_transmission": {"transmissionFactor": 1}, "KHR_materials_ior": {"ior": 9}})");
  const std::string bad = writeGltf(dir, "bad.gltf", g);
  EXPECT_TRUE(test::errorNames(loadGltf(bad), bad,
                               "material 0.extensions.KHR_materials_ior.ior: must be a number in"));
  g.doc["materials"][0]["extensions"] = json::parse(R"({
    "KHR_materials_transmission": {"transmissionFactor": "all"}})");
  const std::string bad2 = writeGltf(dir, "bad2.gltf", g);
  EXPECT_TRUE(
      test::errorNames(loadGltf(bad2), bad2, "KHR_materials_transmission.transmissionFactor"));
}

TEST(GltfLoad, BinaryGlb) {
  TempDir dir;
  const std::string path = writeGlb(dir, "quad.glb", makeTestGltf());
  Expected<Scene> s = loadGltf(path);
  ASSERT_TRUE(s.ok()) << s.error().describe();
  checkTestScene(*s);
  // Through the dispatcher too.
  Expected<Scene> d = loadSceneFile(path);
  ASSERT_TRUE(d.ok()) << d.error().describe();
  EXPECT_EQ(d->triangleCount(), 2u);
}

TEST(GltfLoad, MirroringNodeKeepsFrontFaces) {
  TempDir dir;
  TestGltf g = makeTestGltf();
  g.doc["nodes"][1].erase("rotation");
  g.doc["nodes"][1]["scale"] = {-1, 1, 1};
  Expected<Scene> s = loadGltf(writeGltf(dir, "mirror.gltf", g));
  ASSERT_TRUE(s.ok()) << s.error().describe();
  const Mesh& m = s->meshes[0];
  for (const glm::uvec3& t : m.triangles) {
    const glm::vec3 n =
        glm::cross(m.positions[t.y] - m.positions[t.x], m.positions[t.z] - m.positions[t.x]);
    EXPECT_GT(n.z, 0.0f);  // still facing +z, like the normals
  }
  EXPECT_FLOAT_EQ(m.normals[0].z, 1.0f);
}

TEST(GltfLoad, StripsFansAndNonIndexed) {
  TempDir dir;
  TestGltf g = makeTestGltf();
  json& prim = g.doc["meshes"][0]["primitives"][0];
  // Strip over the corners 0 1 3 2: triangles (v0 v1 v2) = (0 1 3) and, the second reversed as
  // the spec orders it, (v1 v3 v2) = (1 2 3); both counter-clockwise.
  g.bin.resize(96);
  append<uint16_t>(g.bin, {0, 1, 3, 2});
  g.doc["bufferViews"][2]["byteLength"] = 8;
  g.doc["buffers"][0]["byteLength"] = 104;
  g.doc["accessors"][2]["count"] = 4;
  prim["mode"] = 5;
  Expected<Scene> strip = loadGltf(writeGltf(dir, "strip.gltf", g));
  ASSERT_TRUE(strip.ok()) << strip.error().describe();
  ASSERT_EQ(strip->triangleCount(), 2u);
  EXPECT_EQ(strip->meshes[0].triangles[0], glm::uvec3(0, 1, 3));
  EXPECT_EQ(strip->meshes[0].triangles[1], glm::uvec3(1, 2, 3));
  // Non-indexed fan over 0 1 2 3: (0 1 2) (0 2 3).
  prim.erase("indices");
  prim["mode"] = 6;
  Expected<Scene> fan = loadGltf(writeGltf(dir, "fan.gltf", g));
  ASSERT_TRUE(fan.ok()) << fan.error().describe();
  ASSERT_EQ(fan->triangleCount(), 2u);
  EXPECT_EQ(fan->meshes[0].triangles[1], glm::uvec3(0, 2, 3));
}

using test::errorNames;

TEST(GltfLoad, ErrorsNameFileAndPlace) {
  TempDir dir;
  {
    TestGltf g = makeTestGltf();
    const uint16_t nine = 9;
    std::memcpy(g.bin.data() + 96 + 2 * 5, &nine, 2);  // index element 5 -> 9 (4 vertices)
    const std::string p = writeGltf(dir, "badindex.gltf", g);
    EXPECT_TRUE(errorNames(loadGltf(p), p, "accessor 2 (mesh 0 primitive 0 indices), element 5"));
    const std::string b = writeGlb(dir, "badindex.glb", g);
    EXPECT_TRUE(errorNames(loadGltf(b), b, "element 5"));
  }
  {
    TestGltf g = makeTestGltf();
    const float nan = std::numeric_limits<float>::quiet_NaN();
    std::memcpy(g.bin.data() + 2 * 12 + 4, &nan, 4);  // vertex 2's y
    const std::string p = writeGltf(dir, "nan.gltf", g);
    EXPECT_TRUE(errorNames(loadGltf(p), p, "accessor 0 (mesh 0 primitive 0 POSITION), vertex 2"));
  }
  {
    TestGltf g = makeTestGltf();
    g.doc["accessors"][1]["count"] = 5;  // runs past bufferView 1
    const std::string p = writeGltf(dir, "bounds.gltf", g);
    EXPECT_TRUE(errorNames(loadGltf(p), p, "accessor 1"));
  }
  {
    TestGltf g = makeTestGltf();
    g.doc["bufferViews"][2]["byteOffset"] = 100;  // 100 + 12 > 108
    const std::string p = writeGltf(dir, "view.gltf", g);
    EXPECT_TRUE(errorNames(loadGltf(p), p,
                           "bufferViews[2]: byteOffset 100 + byteLength 12 lie "
                           "outside buffer 0 (108 bytes)"));
  }
  {
    TestGltf g = makeTestGltf();
    g.doc["accessors"][0]["componentType"] = 5123;  // positions as unsigned shorts
    const std::string p = writeGltf(dir, "type.gltf", g);
    EXPECT_TRUE(errorNames(loadGltf(p), p, "accessor 0"));
  }
  {
    TestGltf g = makeTestGltf();
    // A required extension Penumbra does not implement is refused by name.
    g.doc["extensionsUsed"].push_back("KHR_materials_clearcoat");
    g.doc["extensionsRequired"] = {"KHR_materials_clearcoat"};
    const std::string p = writeGltf(dir, "clearcoat.gltf", g);
    EXPECT_TRUE(errorNames(loadGltf(p), p,
                           "extensionsRequired: the file requires "
                           "KHR_materials_clearcoat"));
  }
  {
    TestGltf g = makeTestGltf();
    g.doc["nodes"][1]["children"] = {0};  // a cycle
    const std::string p = writeGltf(dir, "cycle.gltf", g);
    EXPECT_TRUE(errorNames(loadGltf(p), p, "cycle"));
  }
  {
    TestGltf g = makeTestGltf();
    g.doc["meshes"][0]["primitives"][0]["material"] = 3;
    const std::string p = writeGltf(dir, "material.gltf", g);
    EXPECT_TRUE(errorNames(loadGltf(p), p, "material 3"));
  }
  const std::string broken = dir.write("broken.gltf", "{\"asset\": {\"version\": \"2.0\"}, ");
  EXPECT_TRUE(errorNames(loadGltf(broken), broken, "line 1, column 31: not a valid glTF"));
  {
    TestGltf g = makeTestGltf();
    std::string bytes = g.doc.dump();
    const std::string p = dir.write("truncated.glb", std::string("glTF") + bytes.substr(0, 10));
    EXPECT_TRUE(errorNames(loadGltf(p), p, "cut short"));
  }
  const std::string missing = dir.file("missing.glb");
  EXPECT_TRUE(errorNames(loadGltf(missing), missing, "no such file"));
  const std::string empty = dir.write("empty.gltf", "");
  EXPECT_TRUE(errorNames(loadGltf(empty), empty, "empty"));
}

// A normal that is not a number only shades (Blender has exported NaN normals for degenerate
// faces): the file loads, that vertex is shaded with its triangle's own normal, and one warning
// names the primitive. A position that is not a number refuses the file (ErrorsNameFileAndPlace).
TEST(GltfLoad, NormalsThatAreNotNumbersAreShadedByTheFaceWithAWarning) {
  TempDir dir;
  TestGltf g = makeTestGltf();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(g.bin.data() + 48 + 12 + 8, &nan, 4);  // normal 1's z
  const std::string p = writeGltf(dir, "nannormal.gltf", g);
  Expected<Scene> s = loadGltf(p);
  ASSERT_TRUE(s) << s.error().message;
  ASSERT_EQ(s->meshes.size(), 1u);
  const Mesh& m = s->meshes[0];
  expectNear(m.normals[0], {1, 0, 0});
  expectNear(m.normals[1], {0, 0, 0});  // no direction: shading takes the face's
  const std::vector<glm::vec3> corners = cornerShadingNormals(*s);
  ASSERT_EQ(corners.size(), 6u);
  expectNear(corners[1], {1, 0, 0});  // triangle 0, corner 1 is vertex 1
  size_t named = 0;
  for (const std::string& w : s->warnings) {
    if (w.find("mesh 0 primitive 0: 1 normals are not finite numbers") != std::string::npos)
      ++named;
  }
  EXPECT_EQ(named, 1u);
}

// What exporters write that the specification (or the validator) does not allow, read as viewers
// read it: a scene that lists a child, a colour one float32 rounding above 1, an alpha cutoff
// above 1 (the schema gives it no maximum), and files with nothing to draw refused saying why.
TEST(GltfLoad, WhatExportersWriteOutsideTheRulesReadsAsViewersReadIt) {
  TempDir dir;
  auto warned = [](const Scene& s, const std::string& what) {
    for (const std::string& w : s.warnings) {
      if (w.find(what) != std::string::npos) return true;
    }
    return false;
  };
  {
    // The scene lists only the quad, a child of "root": drawn once, with root's translation.
    TestGltf g = makeTestGltf();
    g.doc["scenes"][0]["nodes"] = {1};
    const std::string p = writeGltf(dir, "child.gltf", g);
    Expected<Scene> s = loadGltf(p);
    ASSERT_TRUE(s) << s.error().describe();
    ASSERT_EQ(s->meshes.size(), 1u);
    expectNear(s->meshes[0].positions[0], {1, 2, 3});
    EXPECT_TRUE(warned(*s, "node 1 is a child of node 0, not a root"));
    // Listed with its parent, and twice: still one quad.
    g.doc["scenes"][0]["nodes"] = {0, 1, 1};
    Expected<Scene> both = loadGltf(writeGltf(dir, "both.gltf", g));
    ASSERT_TRUE(both) << both.error().describe();
    EXPECT_EQ(both->meshes.size(), 1u);
    EXPECT_TRUE(warned(*both, "under node 0"));
    EXPECT_TRUE(warned(*both, "node 1 is listed twice"));
  }
  {
    TestGltf g = makeTestGltf();
    g.doc["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = {1.00000012, 0.5, 0.0, 1};
    g.doc["materials"][0]["alphaMode"] = "MASK";
    g.doc["materials"][0]["alphaCutoff"] = 1.1;
    Expected<Scene> s = loadGltf(writeGltf(dir, "rounding.gltf", g));
    ASSERT_TRUE(s) << s.error().describe();
    EXPECT_EQ(s->materials[0].reflectance.x, 1.0f);  // clamped
    EXPECT_TRUE(s->materials[0].hasCutouts());       // alpha 1 is below the cutoff: all a hole
    g.doc["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = {1.001, 0.5, 0.0, 1};
    const std::string p = writeGltf(dir, "above.gltf", g);
    EXPECT_TRUE(errorNames(loadGltf(p), p, "baseColorFactor[0]"));
  }
  {
    TestGltf g = makeTestGltf();
    g.doc["meshes"][0]["primitives"][0]["mode"] = 1;  // lines
    const std::string p = writeGltf(dir, "lines.gltf", g);
    EXPECT_TRUE(errorNames(loadGltf(p), p, "are points or lines, which Penumbra does not draw"));
    g.doc["meshes"][0]["primitives"][0]["mode"] = 4;
    g.doc["nodes"][1].erase("mesh");
    const std::string q = writeGltf(dir, "nomesh.gltf", g);
    EXPECT_TRUE(errorNames(loadGltf(q), q, "none of its nodes holds a mesh"));
  }
}

TEST(GltfLoad, ADeepChainOfNodesLoadsWithItsTransformsComposed) {
  // 20,000 nodes, each a child of the one before and moved 1 mm along x; the last holds the
  // quad. A recursive walk overflows the stack long before.
  TempDir dir;
  TestGltf g = makeTestGltf();
  const int depth = 20000;
  json nodes = json::array();
  for (int i = 0; i < depth; ++i) {
    json n = {{"translation", {0.001, 0.0, 0.0}}};
    if (i + 1 < depth) n["children"] = {i + 1};
    if (i + 1 == depth) n["mesh"] = 0;
    nodes.push_back(n);
  }
  g.doc["nodes"] = nodes;
  g.doc["scenes"][0]["nodes"] = {0};
  g.doc.erase("extensionsUsed");
  g.doc["extensions"].clear();
  g.doc.erase("cameras");
  Expected<Scene> s = loadGltf(writeGltf(dir, "chain.gltf", g));
  ASSERT_TRUE(s.ok()) << s.error().describe();
  ASSERT_EQ(s->meshes.size(), 1u);
  expectNear(s->meshes[0].positions[0], {0.001f * depth, 0, 0}, 1e-3f);
  expectNear(s->meshes[0].positions[2], {0.001f * depth + 1, 1, 0}, 1e-3f);
}

TEST(GltfLoad, HostileFilesAreRefusedBeforeTheWork) {
  TempDir dir;
  {
    // A DAG: node 0 lists its child twice; 30 such levels would instance the quad 2^30 times.
    TestGltf g = makeTestGltf();
    g.doc["nodes"][0]["children"] = {1, 1};
    const std::string p = writeGltf(dir, "twice.gltf", g);
    EXPECT_TRUE(errorNames(loadGltf(p), p, "child 1 is listed twice"));
  }
  {
    // ... and a node with two parents.
    TestGltf g = makeTestGltf();
    g.doc["nodes"][2]["children"] = {1};
    const std::string p = writeGltf(dir, "twoparents.gltf", g);
    EXPECT_TRUE(errorNames(loadGltf(p), p, "at most one parent"));
  }
  {
    // A scene that lists a child node as a root: drawn once, under its parent
    // (WhatExportersWriteOutsideTheRulesReadsAsViewersReadIt).
    TestGltf g = makeTestGltf();
    g.doc["scenes"][0]["nodes"] = {0, 1};
    const std::string p = writeGltf(dir, "childroot.gltf", g);
    Expected<Scene> s = loadGltf(p);
    ASSERT_TRUE(s) << s.error().describe();
    EXPECT_EQ(s->meshes.size(), 1u);
  }
  {
    // A mesh instanced by many nodes whose accessors claim 3e7 triangles each: refused by the
    // count, before any buffer is read.
    TestGltf g = makeTestGltf();
    json children = json::array();
    for (int i = 0; i < 100; ++i) {
      g.doc["nodes"].push_back({{"mesh", 0}});
      children.push_back(5 + i);
    }
    g.doc["nodes"][0]["children"] = children;
    g.doc["accessors"][2]["count"] = 90000000;
    const std::string p = writeGltf(dir, "instances.gltf", g);
    EXPECT_TRUE(errorNames(loadGltf(p), p, "3000000000 triangles"));
  }
  {
    // extras nested 100,000 deep: refused with the place, not handed to the JSON parser.
    TestGltf g = makeTestGltf();
    std::string text = g.doc.dump();
    const std::string deep = std::string(100000, '[') + std::string(100000, ']');
    text.insert(1, "\"extras\": " + deep + ", ");
    const std::string p = dir.write("deep.gltf", text);
    EXPECT_TRUE(errorNames(loadGltf(p), p, "line 1, column 267: JSON nested more than 256"));
  }
  {
    TestGltf g = makeTestGltf();
    g.doc["asset"]["version"] = "1.0";
    const std::string p = writeGltf(dir, "v1.gltf", g);
    EXPECT_TRUE(errorNames(loadGltf(p), p, "asset.version: '1.0'"));
  }
  {
    // GLB version 1 (glTF 1.0's binary extension).
    TestGltf g = makeTestGltf();
    const std::string p = writeGlb(dir, "v1.glb", g);
    Expected<std::string> bytes = readFile(p);
    ASSERT_TRUE(bytes.ok());
    (*bytes)[4] = 1;
    dir.write("v1.glb", *bytes);
    EXPECT_TRUE(errorNames(loadGltf(p), p, "GLB version 1"));
  }
  {
    TestGltf g = makeTestGltf();
    g.doc["buffers"][0]["uri"] = ".";
    const std::string p = dir.write("dot.gltf", g.doc.dump());
    EXPECT_TRUE(errorNames(loadGltf(p), p, "buffers[0]: '"));
    EXPECT_TRUE(errorNames(loadGltf(p), p, "is a directory, not a file"));
  }
}

TEST(GltfLoad, AMissingTextureImageIsAnErrorNamingTheMaterialAndTheFile) {
  TempDir dir;
  TestGltf g = makeTestGltf();
  g.doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {{"index", 0}};
  g.doc["textures"] = json::array({{{"source", 0}}});
  g.doc["images"] = json::array({{{"uri", "nowhere.png"}}});
  const std::string path = writeGltf(dir, "tex.gltf", g);
  Expected<Scene> s = loadGltf(path);
  ASSERT_FALSE(s.ok());
  EXPECT_TRUE(test::errorNames(s, path, "nowhere.png"));
  EXPECT_TRUE(test::errorNames(s, path, "'lamp'"));
}

TEST(GltfLoad, NormalTextureIsReadAsDataWithItsScale) {
  // A 2 x 2 PNG whose stored bytes are (200, 128, 255): the normal map holds 200/255, not the
  // sRGB-decoded value; normalTexture.scale becomes the material's normal_scale.
  TempDir dir;
  Image png(2, 2);
  for (glm::vec3& p : png.pixels) {
    // Display-linear values that encode to the bytes wanted (IEC 61966-2-1 inverse).
    auto linear = [](double b) {
      const double e = b / 255.0;
      return float(e <= 0.04045 ? e / 12.92 : std::pow((e + 0.055) / 1.055, 2.4));
    };
    p = glm::vec3(linear(200), linear(128), linear(255));
  }
  ToneMapSettings none;
  none.op = ToneMapOperator::kNone;
  ASSERT_TRUE(writeImage(dir.file("n.png"), png, none).ok());
  TestGltf g = makeTestGltf();
  g.doc["materials"][0]["normalTexture"] = {{"index", 0}, {"scale", 0.5}};
  g.doc["textures"] = json::array({{{"source", 0}}});
  g.doc["images"] = json::array({{{"uri", "n.png"}}});
  Expected<Scene> s = loadGltf(writeGltf(dir, "normal.gltf", g));
  ASSERT_TRUE(s.ok()) << s.error().describe();
  const Material& m = s->materials[0];
  ASSERT_TRUE(m.normal_map);
  EXPECT_EQ(m.normal_map->width, 2);
  EXPECT_NEAR(m.normal_map->pixels[0].x, 200.0f / 255.0f, 1e-6f);
  EXPECT_NEAR(m.normal_map->pixels[0].y, 128.0f / 255.0f, 1e-6f);
  EXPECT_FLOAT_EQ(m.normal_scale, 0.5f);
  // On another UV set: kept out, with a warning.
  g.doc["materials"][0]["normalTexture"]["texCoord"] = 1;
  Expected<Scene> other = loadGltf(writeGltf(dir, "normal1.gltf", g));
  ASSERT_TRUE(other.ok()) << other.error().describe();
  EXPECT_FALSE(other->materials[0].normal_map);
  bool warned = false;
  for (const std::string& w : other->warnings) warned |= w.find("TEXCOORD_1") != std::string::npos;
  EXPECT_TRUE(warned);
}

}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {

// Values of the wrong type or length are refused with their place, never read as a default (a
// baseColorFactor of three numbers or of a string as white, a matrix of strings as the identity).
TEST(GltfLoad, ValuesOfTheWrongShapeAreRefusedWithTheirPlace) {
  TempDir dir;
  const struct {
    const char* pointer;
    json value;
    const char* place;
  } cases[] = {
      {"/materials/0/pbrMetallicRoughness/baseColorFactor",
       {0.5, 0.25, 0.125},
       "materials[0].pbrMetallicRoughness.baseColorFactor"},
      {"/materials/0/pbrMetallicRoughness/baseColorFactor", "grey",
       "materials[0].pbrMetallicRoughness.baseColorFactor"},
      {"/materials/0/pbrMetallicRoughness/baseColorFactor",
       {0.5, 0.25, 2.0, 1.0},
       "baseColorFactor[2]"},
      {"/materials/0/pbrMetallicRoughness/metallicFactor", "0", "metallicFactor"},
      {"/materials/0/emissiveFactor", {1, "0.5", 0.25}, "materials[0].emissiveFactor[1]"},
      {"/materials/0/emissiveFactor", {-1, 0.5, 0.25}, "materials[0].emissiveFactor[0]"},
      {"/materials/0/doubleSided", "yes", "materials[0].doubleSided"},
      {"/nodes/1/matrix",
       json::array(
           {"1", "0", "0", "0", "0", "1", "0", "0", "0", "0", "1", "0", "0", "0", "0", "1"}),
       "nodes[1].matrix[0]"},
      {"/nodes/1/scale", {2, 2}, "nodes[1].scale"},
      {"/nodes/0/translation", "up", "nodes[0].translation"},
      {"/nodes/1/rotation", {0, 2, 0, 1}, "nodes[1].rotation[1]"},
      {"/nodes/0/children", {1, 2.5}, "nodes[0].children[1]"},
      {"/cameras/0/perspective/yfov", 0, "cameras[0].perspective.yfov"},
      {"/extensions/KHR_lights_punctual/lights/0/intensity", "bright",
       "extensions.KHR_lights_punctual.lights[0].intensity"},
      {"/extensions/KHR_lights_punctual/lights/0/color", {1, 1}, "lights[0].color"},
  };
  for (const auto& c : cases) {
    TestGltf g = makeTestGltf();
    g.doc[json::json_pointer(c.pointer)] = c.value;
    for (const std::string& path : {writeGltf(dir, "v.gltf", g), writeGlb(dir, "v.glb", g)}) {
      const Expected<Scene> s = loadGltf(path);
      ASSERT_FALSE(s.ok()) << c.pointer << " = " << c.value.dump();
      EXPECT_EQ(s.error().kind, ErrorKind::kInput);
      EXPECT_EQ(s.error().file, path);
      EXPECT_NE(s.error().describe().find(c.place), std::string::npos) << s.error().describe();
    }
  }
  // The document itself loads, and its right-shaped values are read as given.
  TestGltf g = makeTestGltf();
  const Expected<Scene> good = loadGltf(writeGltf(dir, "ok.gltf", g));
  ASSERT_TRUE(good.ok()) << good.error().describe();
  checkTestScene(*good);
}

}  // namespace
}  // namespace penumbra
