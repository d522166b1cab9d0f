// The lightmap attached to a glTF asset (io/gltf_lightmapped.h) and its RGBM encoding
// (methods/bake_output.h): a file written here with a mesh instanced by two nodes, a triangle
// strip and a material shared with a primitive that already uses TEXCOORD_1, read back through
// the engine's own loader; and the 8-bit encoding's stated precision.
#include "penumbra/io/gltf_lightmapped.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/methods/bake_output.h"
#include "penumbra/scene/builtin.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>

namespace penumbra {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::base64;
using test::TempDir;

// Mesh 0: a unit quad (4 vertices, indexed, TEXCOORD_0) instanced by nodes 0 and 1 (the second
// 2 m to the right), material 0. Mesh 1: the same quad as a triangle strip with TEXCOORD_0 and
// TEXCOORD_1 (its own texture's UVs), also material 0, at node 2. Node 3 holds no mesh.
std::string writeInstancedGltf(const TempDir& dir) {
  std::string bin;
  test::appendBytes<float>(bin, {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0});  // positions, 0
  test::appendBytes<float>(bin, {0, 0, 1, 0, 1, 1, 0, 1});              // uv, 48
  test::appendBytes<uint16_t>(bin, {0, 1, 2, 0, 2, 3});                 // indices, 80
  test::appendBytes<uint16_t>(bin, {0, 1, 3, 2});                       // strip, 92
  json doc = {
      {"asset", {{"version", "2.0"}, {"generator", "test"}, {"extras", {{"kept", 7}}}}},
      {"scene", 0},
      {"scenes", {{{"nodes", {0, 1, 2, 3}}}}},
      {"nodes",
       {{{"mesh", 0}, {"name", "a"}},
        {{"mesh", 0}, {"name", "b"}, {"translation", {2, 0, 0}}},
        {{"mesh", 1}, {"name", "strip"}, {"translation", {0, 0, -2}}, {"extras", {{"x", 1}}}},
        {{"name", "empty"}}}},
      {"meshes",
       {{{"primitives",
          {{{"attributes", {{"POSITION", 0}, {"TEXCOORD_0", 1}}},
            {"indices", 2},
            {"material", 0}}}}},
        {{"primitives",
          {{{"attributes", {{"POSITION", 0}, {"TEXCOORD_0", 1}, {"TEXCOORD_1", 1}}},
            {"indices", 3},
            {"mode", 5},
            {"material", 0}}}}}}},
      {"materials",
       {{{"name", "m"},
         {"pbrMetallicRoughness", {{"baseColorFactor", {0.5, 0.4, 0.3, 1.0}}}},
         {"extras", {{"kept", true}}}}}},
      {"accessors",
       {{{"bufferView", 0},
         {"componentType", 5126},
         {"count", 4},
         {"type", "VEC3"},
         {"min", {0, 0, 0}},
         {"max", {1, 1, 0}}},
        {{"bufferView", 1}, {"componentType", 5126}, {"count", 4}, {"type", "VEC2"}},
        {{"bufferView", 2}, {"componentType", 5123}, {"count", 6}, {"type", "SCALAR"}},
        {{"bufferView", 3}, {"componentType", 5123}, {"count", 4}, {"type", "SCALAR"}}}},
      {"bufferViews",
       {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 48}},
        {{"buffer", 0}, {"byteOffset", 48}, {"byteLength", 32}},
        {{"buffer", 0}, {"byteOffset", 80}, {"byteLength", 12}},
        {{"buffer", 0}, {"byteOffset", 92}, {"byteLength", 8}}}},
      {"buffers",
       {{{"byteLength", bin.size()},
         {"uri", "data:application/octet-stream;base64," + base64(bin)}}}}};
  return dir.write("instanced.gltf", doc.dump());
}

TEST(GltfLightmapped, InstancesStripsAndSharedMaterialsGetTheirOwnLightmapUvs) {
  TempDir dir;
  const std::string path = writeInstancedGltf(dir);
  Expected<Scene> scene = loadScene(path);
  ASSERT_TRUE(scene.ok()) << scene.error().describe();
  const std::vector<GltfTriangleSource> sources = gltfTriangleSources(*scene);
  ASSERT_EQ(sources.size(), 6u);  // 2 + 2 instanced, 2 of the strip
  // Lightmap UVs: distinct for every corner of every triangle, as charts cut at every edge.
  std::vector<TriangleLightmapUvs> uvs(sources.size());
  for (size_t t = 0; t < uvs.size(); ++t) {
    for (int k = 0; k < 3; ++k) uvs[t].uv[k] = glm::vec2(0.1f * float(t) + 0.01f * float(k), 0.5f);
  }
  Expected<GltfDocument> doc = readGltfDocument(path);
  ASSERT_TRUE(doc.ok()) << doc.error().describe();
  LightmapReference lm{"lm.png", "lm.exr", 2.5, 8, 8};
  const std::string out = (dir.path() / "out.gltf").string();
  ASSERT_TRUE(
      writeLightmappedGltf(std::move(*doc), sources, uvs, lm, {{"method", "test"}}, out, "out.bin")
          .ok());
  const json j = test::readJson(out);
  // The mesh instanced twice is copied for its second node; node 3 and extras untouched.
  ASSERT_EQ(j["meshes"].size(), 3u);
  EXPECT_EQ(j["nodes"][0]["mesh"], 0);
  EXPECT_EQ(j["nodes"][1]["mesh"], 2);
  EXPECT_EQ(j["nodes"][2]["extras"]["x"], 1);
  EXPECT_EQ(j["nodes"][3], (json{{"name", "empty"}}));
  EXPECT_EQ(j["asset"]["extras"]["kept"], 7);
  EXPECT_EQ(j["asset"]["extras"]["penumbra"]["method"], "test");
  EXPECT_EQ(j["asset"]["extras"]["penumbra"]["source_generator"], "test");
  // Material 0 serves TEXCOORD_1 (meshes 0, 2); the strip needs TEXCOORD_2, so a copy.
  ASSERT_EQ(j["materials"].size(), 2u);
  EXPECT_EQ(j["materials"][0]["extensions"]["PENUMBRA_lightmap"]["texCoord"], 1);
  EXPECT_EQ(j["materials"][1]["extensions"]["PENUMBRA_lightmap"]["texCoord"], 2);
  EXPECT_EQ(j["materials"][1]["extras"]["kept"], true);
  EXPECT_EQ(j["meshes"][1]["primitives"][0]["material"], 1);
  const json& ext = j["materials"][0]["extensions"]["PENUMBRA_lightmap"];
  EXPECT_EQ(ext["encoding"], "RGBM");
  EXPECT_DOUBLE_EQ(ext["scale"].get<double>(), 2.5);
  EXPECT_EQ(ext["exr"], "lm.exr");
  const json& texture = j["textures"][ext["index"].get<size_t>()];
  EXPECT_EQ(j["images"][texture["source"].get<size_t>()]["uri"], "lm.png");
  // One buffer, the .bin beside the file.
  ASSERT_EQ(j["buffers"].size(), 1u);
  EXPECT_EQ(j["buffers"][0]["uri"], "out.bin");
  EXPECT_EQ(j["buffers"][0]["byteLength"].get<size_t>(), fs::file_size(dir.path() / "out.bin"));
  // The strip became a list; every corner split off (6 vertices a quad), POSITION's bounds exact.
  const json& strip = j["meshes"][1]["primitives"][0];
  EXPECT_EQ(strip["mode"], 4);
  const json& position = j["accessors"][strip["attributes"]["POSITION"].get<size_t>()];
  EXPECT_EQ(position["count"], 6);
  EXPECT_EQ(position["min"], (json{0.0, 0.0, 0.0}));
  EXPECT_EQ(position["max"], (json{1.0, 1.0, 0.0}));

  // Read back by the engine: the same triangles in the same places, and each corner's lightmap
  // UV on the set the material names.
  Expected<Scene> back = loadScene(out);
  ASSERT_TRUE(back.ok()) << back.error().describe();
  ASSERT_EQ(back->meshes.size(), scene->meshes.size());
  size_t t = 0;
  for (size_t m = 0; m < back->meshes.size(); ++m) {
    const Mesh& a = scene->meshes[m];
    const Mesh& b = back->meshes[m];
    ASSERT_EQ(a.triangles.size(), b.triangles.size());
    const int set = m == 2 ? 2 : 1;
    const std::vector<glm::vec2>& lightmap_uv = b.uvSet(uint32_t(set));
    ASSERT_EQ(lightmap_uv.size(), b.positions.size()) << m;
    for (size_t i = 0; i < a.triangles.size(); ++i, ++t) {
      for (int k = 0; k < 3; ++k) {
        EXPECT_EQ(a.positions[a.triangles[i][k]], b.positions[b.triangles[i][k]]);
        EXPECT_EQ(a.uvs[a.triangles[i][k]], b.uvs[b.triangles[i][k]]);  // TEXCOORD_0 kept
        EXPECT_EQ(lightmap_uv[b.triangles[i][k]], uvs[t].uv[k]) << m << " " << i << " " << k;
      }
    }
  }
  EXPECT_EQ(back->materials[0].reflectance, scene->materials[0].reflectance);
}

// A mesh under a plain node and under an EXT_mesh_gpu_instancing node of one copy: the copy
// gets its own node and mesh in the lightmapped asset, as any instanced copy does, and each
// triangle reads back where it was with its own lightmap UVs (a single copy was once left on its
// node, so the baked asset drew it twice, with the plain node's UVs).
TEST(GltfLightmapped, ASingleGpuInstanceIsItsOwnCopy) {
  TempDir dir;
  std::string bin;
  test::appendBytes<float>(bin, {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0});  // positions, 0
  test::appendBytes<float>(bin, {0, 0, 1, 0, 1, 1, 0, 1});              // uv, 48
  test::appendBytes<uint16_t>(bin, {0, 1, 2, 0, 2, 3});                 // indices, 80
  test::appendBytes<uint16_t>(bin, {0, 0});                             // padding, 92
  test::appendBytes<float>(bin, {3, 0, 0});                             // translation, 96
  const json doc = {
      {"asset", {{"version", "2.0"}}},
      {"extensionsUsed", {"EXT_mesh_gpu_instancing"}},
      {"scenes", {{{"nodes", {0, 1}}}}},
      {"nodes",
       {{{"mesh", 0}, {"name", "plain"}},
        {{"mesh", 0},
         {"name", "one copy"},
         {"extensions", {{"EXT_mesh_gpu_instancing", {{"attributes", {{"TRANSLATION", 3}}}}}}}}}},
      {"meshes",
       {{{"primitives",
          {{{"attributes", {{"POSITION", 0}, {"TEXCOORD_0", 1}}}, {"indices", 2}}}}}}},
      {"accessors",
       {{{"bufferView", 0},
         {"componentType", 5126},
         {"count", 4},
         {"type", "VEC3"},
         {"min", {0, 0, 0}},
         {"max", {1, 1, 0}}},
        {{"bufferView", 1}, {"componentType", 5126}, {"count", 4}, {"type", "VEC2"}},
        {{"bufferView", 2}, {"componentType", 5123}, {"count", 6}, {"type", "SCALAR"}},
        {{"bufferView", 3}, {"componentType", 5126}, {"count", 1}, {"type", "VEC3"}}}},
      {"bufferViews",
       {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 48}},
        {{"buffer", 0}, {"byteOffset", 48}, {"byteLength", 32}},
        {{"buffer", 0}, {"byteOffset", 80}, {"byteLength", 12}},
        {{"buffer", 0}, {"byteOffset", 96}, {"byteLength", 12}}}},
      {"buffers",
       {{{"byteLength", bin.size()},
         {"uri", "data:application/octet-stream;base64," + base64(bin)}}}}};
  const std::string path = dir.write("one.gltf", doc.dump());
  Expected<Scene> scene = loadScene(path);
  ASSERT_TRUE(scene.ok()) << scene.error().describe();
  ASSERT_EQ(scene->triangleCount(), 4u);
  const std::vector<GltfTriangleSource> sources = gltfTriangleSources(*scene);
  std::vector<TriangleLightmapUvs> uvs(sources.size());
  for (size_t t = 0; t < uvs.size(); ++t) {
    for (int k = 0; k < 3; ++k) uvs[t].uv[k] = glm::vec2(0.1f * float(t) + 0.01f * float(k), 0.5f);
  }
  Expected<GltfDocument> plain = readGltfDocument(path);
  ASSERT_TRUE(plain.ok()) << plain.error().describe();
  const std::string out = (dir.path() / "out.gltf").string();
  ASSERT_TRUE(writeLightmappedGltf(std::move(*plain), sources, uvs,
                                   LightmapReference{"lm.png", "lm.exr", 2.5, 8, 8}, {}, out,
                                   "out.bin")
                  .ok());
  Expected<Scene> back = loadScene(out);
  ASSERT_TRUE(back.ok()) << back.error().describe();
  ASSERT_EQ(back->triangleCount(), 4u);  // not drawn twice
  ASSERT_EQ(back->meshes.size(), scene->meshes.size());
  size_t t = 0;
  for (size_t m = 0; m < back->meshes.size(); ++m) {
    const Mesh& a = scene->meshes[m];
    const Mesh& b = back->meshes[m];
    const std::vector<glm::vec2>& lightmap_uv = b.uvSet(1);
    ASSERT_EQ(lightmap_uv.size(), b.positions.size()) << m;
    for (size_t i = 0; i < a.triangles.size(); ++i, ++t) {
      for (int k = 0; k < 3; ++k) {
        EXPECT_EQ(a.positions[a.triangles[i][k]], b.positions[b.triangles[i][k]]);
        EXPECT_EQ(lightmap_uv[b.triangles[i][k]], uvs[t].uv[k]) << m << " " << i << " " << k;
      }
    }
  }
}

// A sparse accessor under a lightmapped primitive is written out densely (io/gltf/gltf_plain.cpp):
// its values with the substitution made, the primitive's vertices split as any other attribute.
TEST(GltfLightmapped, SparseAccessorsUnderALightmappedPrimitiveAreWrittenDensely) {
  TempDir dir;
  json doc = test::readJson(writeInstancedGltf(dir));
  // An attribute the engine does not read (an application's own), sparse.
  json sparse = doc["accessors"][1];
  sparse["sparse"] = {{"count", 1},
                      {"indices", {{"bufferView", 2}, {"componentType", 5123}}},
                      {"values", {{"bufferView", 1}}}};
  doc["accessors"].push_back(sparse);
  doc["meshes"][0]["primitives"][0]["attributes"]["_EXTRA"] = 4;
  const std::string path = dir.write("sparse.gltf", doc.dump());
  Expected<Scene> scene = loadScene(path);
  ASSERT_TRUE(scene.ok()) << scene.error().describe();
  const std::vector<GltfTriangleSource> sources = gltfTriangleSources(*scene);
  std::vector<TriangleLightmapUvs> uvs(sources.size());
  for (size_t t = 0; t < uvs.size(); ++t) uvs[t].uv[1] = glm::vec2(0.1f * float(t), 0.0f);
  Expected<GltfDocument> read = readGltfDocument(path);
  ASSERT_TRUE(read.ok()) << read.error().describe();
  const Status s = writeLightmappedGltf(std::move(*read), sources, uvs, {}, {},
                                        (dir.path() / "o.gltf").string(), "o.bin");
  ASSERT_TRUE(s.ok()) << s.error().describe();
  const json out = test::readJson((dir.path() / "o.gltf").string());
  for (const json& a : out["accessors"]) EXPECT_FALSE(a.contains("sparse"));
  EXPECT_TRUE(loadScene((dir.path() / "o.gltf").string()).ok());
}

// A scene that is not a glTF file becomes one: its triangles, UVs, materials and camera.
TEST(GltfLightmapped, AScenesOwnDocumentHoldsItsTrianglesMaterialsAndCamera) {
  TempDir dir;
  Expected<Scene> scene = builtinScene("cornell");
  ASSERT_TRUE(scene.ok());
  std::vector<GltfTriangleSource> sources;
  GltfDocument doc = documentFromScene(*scene, sources);
  std::vector<TriangleLightmapUvs> uvs(sources.size());
  for (size_t t = 0; t < uvs.size(); ++t) {
    for (int k = 0; k < 3; ++k)
      uvs[t].uv[k] = glm::vec2(float(t) / float(uvs.size()), 0.1f * float(k));
  }
  const std::string out = (dir.path() / "c.gltf").string();
  ASSERT_TRUE(writeLightmappedGltf(std::move(doc), sources, uvs, {"l.png", "l.exr", 1.0, 4, 4}, {},
                                   out, "c.bin")
                  .ok());
  Expected<Scene> back = loadScene(out);
  ASSERT_TRUE(back.ok()) << back.error().describe();
  ASSERT_EQ(back->materials.size(), scene->materials.size());
  for (const Material& want : scene->materials) {
    // The loader numbers materials in order of first use: find it by name.
    const auto got = std::find_if(back->materials.begin(), back->materials.end(),
                                  [&](const Material& m) { return m.name == want.name; });
    ASSERT_NE(got, back->materials.end()) << want.name;
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(got->reflectance[c], want.reflectance[c], 1e-6) << want.name;
      EXPECT_NEAR(got->emission[c], want.emission[c], 1e-6 * (1.0 + want.emission[c]));
    }
    EXPECT_EQ(got->two_sided, want.two_sided);
  }
  const FlatTriangles a = flattenScene(*scene), b = flattenScene(*back);
  ASSERT_EQ(a.triangles.size(), b.triangles.size());
  double area_a = surfaceArea(a), area_b = surfaceArea(b);
  EXPECT_NEAR(area_a, area_b, 1e-5 * area_a);
  ASSERT_TRUE(back->camera.has_value());
  EXPECT_NEAR(glm::length(back->camera->position - scene->camera->position), 0.0, 1e-5);
  EXPECT_NEAR(back->camera->vertical_fov, scene->camera->vertical_fov, 1e-6);
  const glm::vec3 d0 = glm::normalize(scene->camera->look_at - scene->camera->position);
  const glm::vec3 d1 = glm::normalize(back->camera->look_at - back->camera->position);
  EXPECT_GT(glm::dot(d0, d1), 0.99999f);
}

// RGBM holds every texel within its stated bound: half a step of its multiplier's scale per
// channel, so 0.4% for the brightest channel of a texel above scale / 255, 0.2% above scale / 5;
// zeros stay zero.
TEST(GltfLightmapped, RgbmKeepsTheStatedPrecisionOverTheRange) {
  Image img(64, 64);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> exponent(-4.0f, 3.0f), unit(0.0f, 1.0f);
  for (glm::vec3& p : img.pixels) {
    const float peak = std::pow(10.0f, exponent(rng));
    p = glm::vec3(peak, peak * unit(rng), peak * unit(rng));
  }
  img.pixels[0] = glm::vec3(0.0f);
  const RgbmImage rgbm = encodeRgbm(img);
  const Image back = decodeRgbm(rgbm);
  float peak = 0.0f;
  for (const glm::vec3& p : img.pixels) peak = std::max({peak, p.x, p.y, p.z});
  EXPECT_FLOAT_EQ(float(rgbm.scale), peak);  // nothing clips
  EXPECT_EQ(back.pixels[0], glm::vec3(0.0f));
  size_t bright = 0;
  for (size_t i = 1; i < img.pixels.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      const double want = img.pixels[i][c], got = back.pixels[i][c];
      // Half a step of r, times the decoded scale of a step: |got - want| <= s a / (2 * 255).
      const double a = rgbm.rgba[4 * i + 3] / 255.0;
      EXPECT_LE(std::abs(got - want), rgbm.scale * a / 510.0 * (1.0 + 1e-5)) << i << " " << c;
      // The brightest channel (red here), m = want / scale: relative error at most
      // 1/510 + 1/(130050 m), so 0.4% above scale / 255 and 0.2% above scale / 5.
      const double m = want / rgbm.scale;
      if (c == 0 && m > 1.0 / 255.0) {
        ++bright;
        EXPECT_LE(std::abs(got - want) / want, 1.0 / 510.0 + 1.0 / (130050.0 * m) + 1e-6);
        EXPECT_LT(std::abs(got - want) / want, m > 0.2 ? 0.002 : 0.004);
      }
    }
  }
  EXPECT_GT(bright, 100u);
}

}  // namespace
}  // namespace penumbra
