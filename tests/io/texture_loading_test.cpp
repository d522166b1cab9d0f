// Textures as files carry them: a glTF written as Blender's exporter writes one (base colour
// factor left at 1 beside a texture, embedded PNG and WebP images, a second UV set, vertex
// colours, samplers, KHR_texture_transform, KHR_materials_emissive_strength, alphaMode MASK), an
// OBJ with map_Kd -s/-o, map_Ke and map_d, and the JSON scene's texture slots; and the errors
// that name the material and the image when one is missing or undecodable.
#include "penumbra/io/scene_io.h"
#include "penumbra/scene/surface_textures.h"
#include "support/image_files.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <string>

namespace penumbra {
namespace {

using nlohmann::json;
using test::TempDir;

template <typename T>
void append(std::string& buf, std::initializer_list<T> values) {
  for (T v : values) buf.append(reinterpret_cast<const char*>(&v), sizeof(T));
}

const uint8_t kWhite[4] = {255, 255, 255, 255};
const uint8_t kBlack[4] = {0, 0, 0, 255};
const uint8_t kHole[4] = {255, 255, 255, 0};
const uint8_t kRed[4] = {255, 0, 0, 255};
const uint8_t kGreen[4] = {0, 255, 0, 255};

// Three unit quads (z = 0, 1, 2) with TEXCOORD_0 = (x, y) (glTF: v down the image), TEXCOORD_1 =
// half of that, and COLOR_0 on the first: floor (baseColorTexture, nearest, clamped), screen
// (emissiveTexture on TEXCOORD_1 through KHR_texture_transform, a WebP image), lattice (alpha
// MASK). Images are PNG and WebP in buffer views, as Blender embeds them in a .glb.
std::string blenderLikeGlb(const TempDir& dir, bool missing_image = false) {
  std::string bin;
  // Positions, normals, uv0, uv1, colours (normalised ubyte), indices.
  append<float>(bin, {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0});  // 0: 48
  append<float>(bin, {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1});  // 48: 48
  append<float>(bin, {0, 0, 1, 0, 1, 1, 0, 1});              // 96: 32
  append<float>(bin, {0, 0, 0.5f, 0, 0.5f, 0.5f, 0, 0.5f});  // 128: 32
  append<uint8_t>(bin, {255, 255, 255, 255, 128, 128, 128, 255, 255, 255, 255, 255, 255, 255, 255,
                        255});                // 160: 16
  append<uint16_t>(bin, {0, 1, 2, 0, 2, 3});  // 176: 12
  while (bin.size() % 4) bin.push_back('\0');
  const size_t png_at = bin.size();
  const std::string png = test::pngBytes(test::chequer(8, 8, 2, kWhite, kBlack));
  bin += png;
  while (bin.size() % 4) bin.push_back('\0');
  const size_t webp_at = bin.size();
  const std::string webp = test::webpBytes(test::chequer(8, 8, 2, kRed, kGreen));
  bin += webp;
  while (bin.size() % 4) bin.push_back('\0');
  const size_t mask_at = bin.size();
  const std::string mask = test::pngBytes(test::chequer(8, 8, 2, kWhite, kHole));
  bin += mask;
  json doc = json::parse(R"({
    "asset": {"version": "2.0", "generator": "Khronos glTF Blender I/O v3.6.28"},
    "extensionsUsed": ["KHR_texture_transform", "KHR_materials_emissive_strength",
                       "EXT_texture_webp"],
    "extensionsRequired": ["EXT_texture_webp"],
    "scene": 0,
    "scenes": [{"nodes": [0, 1, 2]}],
    "nodes": [{"name": "Floor", "mesh": 0}, {"name": "Screen", "mesh": 1, "translation": [0, 0, 1]},
              {"name": "Lattice", "mesh": 2, "translation": [0, 0, 2]}],
    "meshes": [
      {"name": "Floor", "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1,
        "TEXCOORD_0": 2, "TEXCOORD_1": 3, "COLOR_0": 4}, "indices": 5, "material": 0}]},
      {"name": "Screen", "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1,
        "TEXCOORD_0": 2, "TEXCOORD_1": 3}, "indices": 5, "material": 1}]},
      {"name": "Lattice", "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1,
        "TEXCOORD_0": 2}, "indices": 5, "material": 2}]}],
    "materials": [
      {"name": "Floor", "doubleSided": true, "pbrMetallicRoughness": {
        "baseColorTexture": {"index": 0}, "metallicFactor": 0, "roughnessFactor": 0.5}},
      {"name": "Screen", "emissiveFactor": [1, 1, 1],
       "emissiveTexture": {"index": 1, "texCoord": 1, "extensions": {"KHR_texture_transform": {
         "offset": [0.25, 0], "scale": [2, 2]}}},
       "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 5}},
       "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}},
      {"name": "Lattice", "alphaMode": "MASK", "alphaCutoff": 0.4, "pbrMetallicRoughness": {
        "baseColorFactor": [0.5, 0.5, 0.5, 0.9], "baseColorTexture": {"index": 2}}}],
    "textures": [{"sampler": 0, "source": 0},
                 {"sampler": 1, "extensions": {"EXT_texture_webp": {"source": 1}}},
                 {"sampler": 1, "source": 2}],
    "samplers": [{"magFilter": 9728, "minFilter": 9984, "wrapS": 33071, "wrapT": 33071},
                 {"magFilter": 9729, "minFilter": 9987}],
    "buffers": [{}],
    "bufferViews": [
      {"buffer": 0, "byteOffset": 0, "byteLength": 48},
      {"buffer": 0, "byteOffset": 48, "byteLength": 48},
      {"buffer": 0, "byteOffset": 96, "byteLength": 32},
      {"buffer": 0, "byteOffset": 128, "byteLength": 32},
      {"buffer": 0, "byteOffset": 160, "byteLength": 16},
      {"buffer": 0, "byteOffset": 176, "byteLength": 12}],
    "accessors": [
      {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
       "min": [0, 0, 0], "max": [1, 1, 0]},
      {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
      {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
      {"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC2"},
      {"bufferView": 4, "componentType": 5121, "normalized": true, "count": 4, "type": "VEC4"},
      {"bufferView": 5, "componentType": 5123, "count": 6, "type": "SCALAR"}]
  })");
  doc["buffers"][0]["byteLength"] = bin.size();
  auto view = [&](size_t at, size_t size) {
    doc["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", at}, {"byteLength", size}});
    return doc["bufferViews"].size() - 1;
  };
  doc["images"] = json::array();
  doc["images"].push_back(
      {{"name", "chequer"}, {"mimeType", "image/png"}, {"bufferView", view(png_at, png.size())}});
  doc["images"].push_back(
      {{"name", "screen"}, {"mimeType", "image/webp"}, {"bufferView", view(webp_at, webp.size())}});
  if (missing_image) {
    doc["images"].push_back({{"uri", "textures/lattice.png"}});
  } else {
    doc["images"].push_back({{"name", "lattice"},
                             {"mimeType", "image/png"},
                             {"bufferView", view(mask_at, mask.size())}});
  }
  return dir.write("room.glb", test::glbBytes(doc, bin));
}

TEST(TextureLoading, GltfAsBlenderWritesIt) {
  TempDir dir;
  Expected<Scene> s = loadScene(blenderLikeGlb(dir));
  ASSERT_TRUE(s.ok()) << s.error().describe();
  for (const std::string& w : s->warnings) EXPECT_EQ(w.find("not used"), std::string::npos) << w;
  ASSERT_EQ(s->materials.size(), 3u);
  const Material& floor = s->materials[0];
  ASSERT_TRUE(floor.reflectance_texture);
  EXPECT_EQ(floor.reflectance, glm::vec3(1.0f));  // the factor Blender leaves at 1
  EXPECT_TRUE(floor.reflectance_texture->sampler.nearest);
  EXPECT_EQ(floor.reflectance_texture->sampler.wrap_s, TextureWrap::kClampToEdge);
  const Material& screen = s->materials[1];
  ASSERT_TRUE(screen.emission_texture);
  EXPECT_EQ(screen.emission_texture->uv_set, 1u);
  EXPECT_EQ(screen.emission, glm::vec3(5.0f));
  const Material& lattice = s->materials[2];
  EXPECT_EQ(lattice.alpha_mode, AlphaMode::kMask);
  EXPECT_FLOAT_EQ(lattice.alpha_cutoff, 0.4f);
  EXPECT_FLOAT_EQ(lattice.alpha, 0.9f);
  ASSERT_EQ(s->meshes.size(), 3u);
  EXPECT_EQ(s->meshes[0].extra_uvs.size(), 1u);
  ASSERT_EQ(s->meshes[0].colors.size(), 4u);
  EXPECT_NEAR(s->meshes[0].colors[1].x, 128.0f / 255.0f, 1e-6f);

  const SurfaceTextures st(*s);
  // Floor: nearest lookups of the white (top-left) and black cells, times the vertex colour
  // (1 at corner 0). Triangle 0 is (0, 1, 2): barycentrics (w1, w2) at point (x, y) are
  // (x - y, y), and glTF's v runs down the image, so point (0.1, 0.05) is in the top-left cell.
  // Point (0.05, 0.01): white, times the colours 1, 128/255 and 1 mixed 0.95 : 0.04 : 0.01.
  EXPECT_NEAR(st.reflectance(0, {0.04f, 0.01f}).x, 0.95f + 0.04f * 128.0f / 255.0f + 0.01f, 1e-4f);
  EXPECT_NEAR(st.reflectance(0, {0.5f, 0.2f}).x, 0.0f, 1e-6f);  // point (0.7, 0.2): black
  // Screen: TEXCOORD_1 = (x, y) / 2, transformed to 2 uv + (0.25, 0) = (x + 0.25, y): point
  // (0.1, 0.1) reads the image at (0.35, 0.1), inside the top-left (red) cell; point (0.5, 0.1)
  // at (0.75, 0.1), inside the green one. Bilinear lookups there read one cell only.
  EXPECT_NEAR(st.emission(2, {0.0f, 0.1f}).x, 5.0f, 1e-5f);
  EXPECT_NEAR(st.emission(2, {0.0f, 0.1f}).y, 0.0f, 1e-5f);
  EXPECT_NEAR(st.emission(2, {0.4f, 0.1f}).y, 5.0f, 1e-5f);
  // Lattice: alpha 0.9 x texture (1 or 0): a hole in the right-hand cells.
  EXPECT_TRUE(st.hasCutouts());
  EXPECT_TRUE(st.stops(4, {0.05f, 0.05f}, 0.0f));
  EXPECT_FALSE(st.stops(4, {0.6f, 0.05f}, 0.0f));
}

TEST(TextureLoading, AMissingOrUndecodableImageNamesTheMaterialAndTheFile) {
  TempDir dir;
  const std::string path = blenderLikeGlb(dir, true);
  Expected<Scene> s = loadScene(path);
  ASSERT_FALSE(s.ok());
  const std::string message = s.error().describe();
  EXPECT_NE(message.find("Lattice"), std::string::npos) << message;
  EXPECT_NE(message.find("lattice.png"), std::string::npos) << message;
  EXPECT_NE(message.find("baseColorTexture"), std::string::npos) << message;
  // The file is there but is not an image.
  std::filesystem::create_directories(dir.path() / "textures");
  dir.write("textures/lattice.png", "not an image at all");
  s = loadScene(path);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().describe().find("lattice.png"), std::string::npos) << s.error().describe();
  EXPECT_NE(s.error().describe().find("Lattice"), std::string::npos) << s.error().describe();
}

TEST(TextureLoading, ObjWithMtlMaps) {
  TempDir dir;
  dir.write("floor.png", test::pngBytes(test::chequer(8, 8, 2, kWhite, kBlack)));
  dir.write("screen.jpg", test::jpegBytes(test::chequer(8, 8, 1, kRed, kRed)));
  dir.write("mask.png", test::pngBytes(test::chequer(8, 8, 2, kWhite, kBlack), 1));
  dir.write("room.mtl",
            "newmtl floor\nKd 0.8 0.8 0.8\nmap_Kd -s 2 2 1 -o 0.5 0 0 floor.png\n"
            "newmtl screen\nKd 0 0 0\nKe 0 0 0\nmap_Ke screen.jpg\n"
            "newmtl leaves\nKd 0.3 0.6 0.2\nmap_d mask.png\n"
            "newmtl glass\nKd 0.5 0.5 0.5\nd 0.25\n");
  std::string obj = "mtllib room.mtl\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n";
  for (int k = 0; k < 4; ++k) {
    const std::string z = std::to_string(k);
    obj += "v 0 0 " + z + "\nv 1 0 " + z + "\nv 1 1 " + z + "\nv 0 1 " + z + "\n";
  }
  const char* names[4] = {"floor", "screen", "leaves", "glass"};
  for (int k = 0; k < 4; ++k) {
    const int b = 4 * k + 1;
    obj += std::string("usemtl ") + names[k] + "\nf " + std::to_string(b) + "/1 " +
           std::to_string(b + 1) + "/2 " + std::to_string(b + 2) + "/3 " + std::to_string(b + 3) +
           "/4\n";
  }
  Expected<Scene> s = loadScene(dir.write("room.obj", obj));
  ASSERT_TRUE(s.ok()) << s.error().describe();
  ASSERT_EQ(s->materials.size(), 4u);
  const Material& floor = s->materials[0];
  ASSERT_TRUE(floor.reflectance_texture);
  EXPECT_EQ(floor.reflectance, glm::vec3(1.0f));  // map_Kd in place of Kd, as Blender reads it
  EXPECT_EQ(floor.reflectance_texture->row_u, glm::vec3(2.0f, 0.0f, 0.5f));
  const Material& screen = s->materials[1];
  ASSERT_TRUE(screen.emission_texture);
  EXPECT_EQ(screen.emission, glm::vec3(1.0f));  // Ke 0 beside map_Ke: the map as it is
  EXPECT_TRUE(screen.isEmissive());
  const Material& leaves = s->materials[2];
  ASSERT_TRUE(leaves.coverage_texture);
  EXPECT_EQ(leaves.alpha_mode, AlphaMode::kMask);
  const Material& glass = s->materials[3];
  EXPECT_EQ(glass.alpha_mode, AlphaMode::kBlend);
  EXPECT_FLOAT_EQ(glass.alpha, 0.25f);
  bool warned = false;
  for (const std::string& w : s->warnings)
    warned = warned || w.find("'glass'") != std::string::npos;
  EXPECT_TRUE(warned);

  const SurfaceTextures st(*s);
  // Floor at point (0.1, 0.05): uv' = (2 * 0.1 + 0.5, 2 * 0.05) = (0.7, 0.1); OBJ's v runs up,
  // so the image's (0.7, 0.9): the bottom-right cell, white (cells (1, 1)).
  EXPECT_NEAR(st.reflectance(0, {0.05f, 0.05f}).x, 1.0f, 1e-6f);
  // Leaves: the grey mask's first channel; the black cells are holes.
  // Point (0.9, 0.4) reads the image at (0.9, 0.6), a white cell; point (0.1, 0.05) at
  // (0.1, 0.95), mostly the black cell below the top-left one.
  EXPECT_TRUE(st.isCutout(4));
  EXPECT_TRUE(st.stops(4, {0.5f, 0.4f}, 0.0f));
  EXPECT_FALSE(st.stops(4, {0.05f, 0.05f}, 0.0f));
}

TEST(TextureLoading, ObjMissingMapNamesTheMaterialAndTheFile) {
  TempDir dir;
  dir.write("a.mtl", "newmtl brick\nmap_Kd textures\\brick.png\n");
  Expected<Scene> s = loadScene(
      dir.write("a.obj", "mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl brick\nf 1 2 3\n"));
  ASSERT_FALSE(s.ok());
  const std::string m = s.error().describe();
  EXPECT_NE(m.find("brick"), std::string::npos) << m;
  EXPECT_NE(m.find("textures/brick.png"), std::string::npos) << m;
  EXPECT_NE(m.find("map_Kd"), std::string::npos) << m;
  EXPECT_EQ(s.error().kind, ErrorKind::kInput);
}

TEST(TextureLoading, JsonSceneTextureSlots) {
  TempDir dir;
  dir.write("wall.png", test::pngBytes(test::chequer(8, 8, 2, kWhite, kBlack)));
  dir.write("holes.png", test::pngBytes(test::chequer(8, 8, 2, kWhite, kHole)));
  dir.write("quad.obj",
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
            "f 1/1 2/2 3/3 4/4\n");
  const json scene = {
      {"materials",
       {{"wall",
         {{"reflectance", {0.5, 0.5, 0.5}},
          {"reflectance_texture",
           {{"file", "wall.png"}, {"wrap", "mirror"}, {"filter", "nearest"}, {"scale", {2, 2}}}},
          {"coverage_texture", "holes.png"},
          {"alpha_cutoff", 0.5}}}}},
      {"meshes", {{{"file", "quad.obj"}, {"material", "wall"}}}}};
  Expected<Scene> s = loadScene(dir.write("scene.json", scene.dump()));
  ASSERT_TRUE(s.ok()) << s.error().describe();
  const Material& m = s->materials.back();
  ASSERT_TRUE(m.reflectance_texture);
  EXPECT_EQ(m.reflectance_texture->sampler.wrap_s, TextureWrap::kMirroredRepeat);
  EXPECT_TRUE(m.reflectance_texture->sampler.nearest);
  EXPECT_EQ(m.reflectance, glm::vec3(0.5f));
  EXPECT_EQ(m.alpha_mode, AlphaMode::kMask);  // a coverage texture without a mode: a mask
  // Errors name the slot.
  const json bad = {{"materials", {{"wall", {{"reflectance_texture", {{"file", "nope.png"}}}}}}},
                    {"meshes", {{{"file", "quad.obj"}, {"material", "wall"}}}}};
  Expected<Scene> e = loadScene(dir.write("bad.json", bad.dump()));
  ASSERT_FALSE(e.ok());
  EXPECT_NE(e.error().describe().find("reflectance_texture"), std::string::npos)
      << e.error().describe();
  const json mode = {{"materials", {{"wall", {{"alpha_mode", "sometimes"}}}}},
                     {"meshes", {{{"file", "quad.obj"}, {"material", "wall"}}}}};
  EXPECT_FALSE(loadScene(dir.write("mode.json", mode.dump())).ok());
}

}  // namespace
}  // namespace penumbra
