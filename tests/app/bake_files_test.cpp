// What a bake publishes, checked as a hostile user and a web server would: names percent-encoded
// in URIs so the bake reads back (here and in the page); `--web DIR` made when missing, and
// holding everything the page fetches; no absolute path of the machine in published files; OBJ
// and JSON scenes keep their textures and cut-outs; a checkpoint does not resume onto changed
// textures; MTL `-s u v` keeps its texture; a scene of nothing but holes is refused alike by every
// method.
#include "penumbra/io/asset_files.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/radiosity/checkpoint_io.h"
#include "penumbra/radiosity/radiosity_surface.h"
#include "support/image_files.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace penumbra {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::runCli;
using test::TempDir;

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void put(const fs::path& p, const std::string& bytes) {
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << bytes;
}

// A lit floor under a textured, cut-out card: an OBJ with its MTL (map_Kd with `-s u v`, map_d)
// beside the textures, and a light.
fs::path objScene(const fs::path& dir, const std::string& stem) {
  const uint8_t red[4] = {200, 30, 30, 255}, white[4] = {240, 240, 240, 255};
  const uint8_t on[4] = {255, 255, 255, 255}, off[4] = {0, 0, 0, 0};
  put(dir / "wood tex.png", test::pngBytes(test::chequer(8, 8, 2, red, white)));
  put(dir / "mask.png", test::pngBytes(test::chequer(8, 8, 2, on, off), 2));
  put(dir / (stem + ".mtl"),
      "newmtl card\nKd 1 1 1\nmap_Kd -s 2 2 wood tex.png\nmap_d mask.png\n"
      "newmtl floor\nKd 0.5 0.5 0.5\n");
  put(dir / (stem + ".obj"), "mtllib " + stem +
                                 ".mtl\n"
                                 "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\n"
                                 "v -0.5 0.2 0\nv 0.5 0.2 0\nv 0.5 1.2 0\nv -0.5 1.2 0\n"
                                 "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                                 "usemtl floor\nf 1 4 3 2\n"
                                 "usemtl card\nf 5/1 6/2 7/3 8/4\n");
  const json scene = {
      {"meshes", {{{"file", stem + ".obj"}}}},
      {"lights", {{{"type", "point"}, {"position", {0, 2, 1}}, {"intensity", {3, 3, 3}}}}}};
  put(dir / (stem + ".json"), scene.dump(1));
  return dir / (stem + ".json");
}

TEST(BakeFiles, ObjScenesKeepTextureAndCutOutAndMtlScaleKeepsItsFile) {
  TempDir dir;
  const fs::path scene = objScene(dir.path() / "in", "card");
  // -s 2 2 (two numbers) keeps its file name and scales the UVs.
  Expected<Scene> s = loadSceneFile(scene.string());
  ASSERT_TRUE(s.ok()) << s.error().describe();
  const Material* card = nullptr;
  for (const Material& m : s->materials) {
    if (m.name == "card") card = &m;
  }
  ASSERT_NE(card, nullptr);
  ASSERT_TRUE(card->reflectance_texture.has_value());
  EXPECT_FLOAT_EQ(card->reflectance_texture->row_u.x, 2.0f);
  EXPECT_FLOAT_EQ(card->reflectance_texture->row_v.y, 2.0f);
  ASSERT_TRUE(card->coverage_texture.has_value());

  const auto r = runCli("bake " + scene.string() + " --method matrix --elements 200 --quiet -o " +
                        (dir.path() / "out").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const json doc = json::parse(slurp(dir.path() / "out" / "card.gltf"));
  bool textured = false, masked = false;
  for (const json& m : doc["materials"]) {
    if (m.value("name", std::string()) != "card") continue;
    textured = m["pbrMetallicRoughness"].contains("baseColorTexture");
    masked = m.value("alphaMode", std::string()) == "MASK";
    // The UV scale goes with it.
    EXPECT_TRUE(m["pbrMetallicRoughness"]["baseColorTexture"].contains("extensions"));
  }
  EXPECT_TRUE(textured);
  EXPECT_TRUE(masked);
  ASSERT_TRUE(doc.contains("images"));
  // The baked file reads back, its texture and cut-out with it.
  Expected<Scene> back = loadGltf((dir.path() / "out" / "card.gltf").string());
  ASSERT_TRUE(back.ok()) << back.error().describe();
  bool cut = false;
  for (const Material& m : back->materials) cut = cut || m.hasCutouts();
  EXPECT_TRUE(cut);
}

TEST(BakeFiles, NamesAreEncodedTheWebDirectoryIsMadeAndNoPathOfTheMachineIsPublished) {
  TempDir dir;
  // A scene whose name needs encoding in a URI.
  const fs::path scene = objScene(dir.path() / "in", "room #1+%");
  const fs::path out = dir.path() / "out", web = dir.path() / "site" / "viewer";
  const auto r = runCli("bake '" + scene.string() + "' --method matrix --elements 200 --quiet -o " +
                        out.string() + " --web " + web.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string gltf_text = slurp(out / "room #1+%.gltf");
  const json doc = json::parse(gltf_text);
  EXPECT_EQ(doc["buffers"][0]["uri"], "room%20%231%2B%25.bin");
  // Read back by Penumbra.
  EXPECT_TRUE(loadGltf((out / "room #1+%.gltf").string()).ok());
  // The page's folder was made, holds the bake, and names it by a URI inside it.
  const json manifest = json::parse(slurp(web / "bake.json"));
  const std::string uri = manifest["gltf"];
  EXPECT_EQ(uri.find(".."), std::string::npos) << uri;
  Expected<std::string> file = percentDecode(uri, "bake.json", "gltf");
  ASSERT_TRUE(file.ok());
  EXPECT_TRUE(fs::exists(web / *file)) << uri;
  EXPECT_TRUE(fs::exists(web / "room #1+%.bin"));
  EXPECT_TRUE(fs::exists(web / "index.html"));
  // No absolute path of this machine in anything published.
  const std::string abs = fs::absolute(dir.path()).string();
  for (const auto& entry : fs::recursive_directory_iterator(dir.path() / "site")) {
    if (!entry.is_regular_file() || entry.path().extension() == ".js") continue;
    EXPECT_EQ(slurp(entry.path()).find(abs), std::string::npos) << entry.path();
  }
  EXPECT_EQ(gltf_text.find(abs), std::string::npos);
}

// A checkpoint's fingerprint (radiosity/checkpoint_io.h) holds what textures, vertex colours and
// cut-outs make of every element: a texture or an alpha mode changed since the checkpoint was
// written gives another fingerprint, so --resume refuses it ("another scene"); so does another
// sky or environment.
TEST(BakeFiles, ACheckpointDoesNotResumeOntoChangedTexturesAlphaOrOutsideLight) {
  TempDir dir;
  const fs::path scene = objScene(dir.path() / "in", "card");
  auto fingerprint = [&]() {
    Expected<Scene> s = loadSceneFile(scene.string());
    EXPECT_TRUE(s.ok()) << s.error().describe();
    ChartAtlasOptions atlas;
    atlas.texel_density = 8.0;
    Expected<RadiositySurface> surface = RadiositySurface::build(*s, atlas, true);
    EXPECT_TRUE(surface.ok());
    return std::make_pair(radiosityFingerprint(*s, *surface, true), std::move(*s));
  };
  const auto [original, loaded] = fingerprint();
  EXPECT_EQ(fingerprint().first, original);  // the same files, the same fingerprint
  const uint8_t blue[4] = {20, 20, 220, 255}, white[4] = {240, 240, 240, 255};
  put(dir.path() / "in" / "wood tex.png", test::pngBytes(test::chequer(8, 8, 2, blue, white)));
  EXPECT_NE(fingerprint().first, original);
  // The alpha mode alone.
  Scene blended = loaded;
  for (Material& m : blended.materials) {
    if (m.alpha_mode == AlphaMode::kMask) m.alpha_mode = AlphaMode::kBlend;
  }
  ChartAtlasOptions atlas;
  atlas.texel_density = 8.0;
  Expected<RadiositySurface> surface = RadiositySurface::build(blended, atlas, true);
  ASSERT_TRUE(surface.ok());
  Expected<RadiositySurface> again = RadiositySurface::build(loaded, atlas, true);
  ASSERT_TRUE(again.ok());
  EXPECT_NE(radiosityFingerprint(blended, *surface, true),
            radiosityFingerprint(loaded, *again, true));
  // The light from outside (--environment, --sky): another environment, a sky, another sky.
  const uint64_t dark = radiosityFingerprint(loaded, *again, true);
  Scene lit = loaded;
  lit.environment = glm::vec3(1.0f);
  EXPECT_NE(radiosityFingerprint(lit, *again, true), dark);
  Scene overcast = loaded;
  overcast.sky = Sky{};
  overcast.sky->zenith_luminance = 3000.0;
  overcast.sky->prepare();
  EXPECT_NE(radiosityFingerprint(overcast, *again, true), dark);
  Scene clear = overcast;
  clear.sky->type = 12;
  clear.sky->prepare();
  EXPECT_NE(radiosityFingerprint(clear, *again, true),
            radiosityFingerprint(overcast, *again, true));
}

TEST(BakeFiles, ASceneOfNothingButHolesIsRefusedAlikeByEveryMethod) {
  TempDir dir;
  const uint8_t off[4] = {0, 0, 0, 0};
  put(dir.path() / "hole.png", test::pngBytes(test::chequer(4, 4, 1, off, off)));
  const json scene = {{"materials",
                       {{"lamp",
                         {{"reflectance", {0.5, 0.5, 0.5}},
                          {"emission", {5, 5, 5}},
                          {"reflectance_texture", "hole.png"},
                          {"alpha_mode", "mask"}}}}},
                      {"meshes", {{{"sphere", 2}, {"material", "lamp"}}}}};
  put(dir.path() / "holes.json", scene.dump());
  std::string first;
  for (const char* method :
       {"pathtrace", "whitted", "photons", "progressive", "stochastic", "matrix"}) {
    SCOPED_TRACE(method);
    const auto r = runCli("render " + (dir.path() / "holes.json").string() + " --method " + method +
                          " --width 16 --height 16 --quiet -o " + (dir.path() / "x.png").string());
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("emits no light"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(dir.path() / "x.png"));
  }
}

}  // namespace
}  // namespace penumbra
