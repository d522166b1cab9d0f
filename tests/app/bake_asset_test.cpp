// `penumbra bake --gltf asset` (the default): the input's own glTF with the lightmap attached as
// irradiance (methods/bake_output.h, io/gltf_lightmapped.h). Checked against physics and against
// the input: irradiance times albedo over pi is the radiance the solver found; a point light's
// irradiance on a plane is I h / d^3; the baked textured room (exported by Blender's glTF
// exporter) keeps every material, texture and node, and renders bit for bit as its input does.
#include "penumbra/core/file_util.h"
#include "penumbra/io/image_io.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/methods/bake_output.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/mat2x2.hpp>
#include <glm/matrix.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>

namespace penumbra {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::bilinear;
using test::runCli;
using test::TempDir;

// The lightmap UV set of each material of a baked document, by material name.
std::map<std::string, int> lightmapSets(const json& doc) {
  std::map<std::string, int> sets;
  for (const json& m : doc["materials"]) {
    if (m.contains("extensions") && m["extensions"].contains("PENUMBRA_lightmap")) {
      sets[m.value("name", std::string())] = m["extensions"]["PENUMBRA_lightmap"]["texCoord"];
    }
  }
  return sets;
}

// The same solve written both ways: at every triangle's centroid, the asset's irradiance times
// the material's albedo over pi, plus its emission, is the emissive output's radiance lightmap
// (B = rho E + emission, the radiosity equation), and the RGBM PNG decodes to the EXR.
TEST(BakeAsset, IrradianceTimesAlbedoOverPiIsTheSolvedRadiance) {
  TempDir dir;
  const fs::path asset = dir.path() / "asset", emissive = dir.path() / "emissive";
  const std::string solve = "bake cornell --method progressive --texel-density 20 --quiet -o ";
  const auto a = runCli(solve + asset.string());
  ASSERT_EQ(a.exit_code, 0) << a.output;
  const auto e = runCli(solve + emissive.string() + " --gltf emissive");
  ASSERT_EQ(e.exit_code, 0) << e.output;
  Expected<Image> irradiance = readImage((asset / "cornell_lightmap.exr").string());
  Expected<Image> radiance = readImage((emissive / "cornell_lightmap.exr").string());
  ASSERT_TRUE(irradiance.ok() && radiance.ok());
  ASSERT_EQ(irradiance->width, radiance->width);
  ASSERT_EQ(irradiance->height, radiance->height);

  const json doc = test::readJson((asset / "cornell.gltf").string());
  EXPECT_EQ(doc["asset"]["extras"]["penumbra"]["lights_baked"], true);
  const std::map<std::string, int> sets = lightmapSets(doc);
  Expected<Scene> baked = loadScene((asset / "cornell.gltf").string());
  ASSERT_TRUE(baked.ok()) << baked.error().describe();
  size_t checked = 0;
  double worst = 0.0;
  for (const Mesh& m : baked->meshes) {
    for (size_t t = 0; t < m.triangles.size(); ++t) {
      const Material& mat = baked->materials[m.material_ids[t]];
      ASSERT_TRUE(sets.count(mat.name)) << mat.name;
      const std::vector<glm::vec2>& uv = m.uvSet(uint32_t(sets.at(mat.name)));
      ASSERT_EQ(uv.size(), m.positions.size());
      const glm::uvec3 tri = m.triangles[t];
      const glm::vec2 c = (uv[tri.x] + uv[tri.y] + uv[tri.z]) / 3.0f;
      const glm::vec3 want = bilinear(*radiance, c);
      const glm::vec3 got =
          bilinear(*irradiance, c) * mat.reflectance / float(std::numbers::pi) + mat.emission;
      for (int k = 0; k < 3; ++k) {
        worst = std::max(worst, double(std::abs(got[k] - want[k]) / (want[k] + 1e-3f)));
      }
      ++checked;
    }
  }
  EXPECT_GT(checked, 20u);
  EXPECT_LT(worst, 1e-4);

  // The 8-bit lightmap: RGBM with the materials' scale, within half a step of the multiplier.
  const double scale = doc["materials"][0]["extensions"]["PENUMBRA_lightmap"]["scale"];
  std::ifstream png_file(asset / "cornell_lightmap.png", std::ios::binary);
  const std::string png((std::istreambuf_iterator<char>(png_file)), {});
  Expected<TextureTexels> texels = decodeTextureImage("png", png);
  ASSERT_TRUE(texels.ok());
  ASSERT_EQ(texels->channels, 4);
  RgbmImage rgbm{texels->width, texels->height, scale, texels->rgba8};
  const Image decoded = decodeRgbm(rgbm);
  for (size_t i = 0; i < decoded.pixels.size(); ++i) {
    const double step = scale * (rgbm.rgba[4 * i + 3] / 255.0) / 510.0;
    for (int k = 0; k < 3; ++k) {
      ASSERT_LE(std::abs(decoded.pixels[i][k] - irradiance->pixels[i][k]), step * 1.0001) << i;
    }
  }
}

// A two-sided plane whose front faces away from a point light: the lightmap UVs point at its lit
// side, where the irradiance is the point light's closed form I h / d^3 (a plane sees nothing of
// itself, so there is no interreflection).
TEST(BakeAsset, APlaneLitFromBehindCarriesItsLitSideAndThePointLightsClosedForm) {
  TempDir dir;
  // The unit square at y = 0 facing -y (counter-clockwise seen from below).
  dir.write("plane.obj", "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nf 1 2 3\nf 1 3 4\n");
  const double intensity = 2.0, h = 0.8;
  const std::string scene =
      dir.write("plane.json", json{{"materials", {{"grey", {{"reflectance", {0.5, 0.5, 0.5}}}}}},
                                   {"meshes", {{{"file", "plane.obj"}, {"material", "grey"}}}},
                                   {"lights",
                                    {{{"type", "point"},
                                      {"position", {0.3, h, 0.6}},
                                      {"intensity", {intensity, intensity, intensity}}}}}}
                                  .dump());
  const fs::path out = dir.path() / "out";
  const auto r = runCli("bake " + scene + " --method progressive --texel-density 40 --quiet -o " +
                        out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  Expected<Image> irradiance = readImage((out / "plane_lightmap.exr").string());
  ASSERT_TRUE(irradiance.ok());
  Expected<Scene> baked = loadScene((out / "plane.gltf").string());
  ASSERT_TRUE(baked.ok()) << baked.error().describe();
  const Mesh& m = baked->meshes.at(0);
  const std::vector<glm::vec2>& uv = m.uvSet(1);
  ASSERT_EQ(uv.size(), m.positions.size());
  double worst = 0.0;
  int points = 0;
  for (const glm::uvec3& tri : m.triangles) {
    for (const glm::vec3 w : {glm::vec3(1, 1, 1) / 3.0f, glm::vec3(0.6f, 0.2f, 0.2f),
                              glm::vec3(0.2f, 0.6f, 0.2f), glm::vec3(0.2f, 0.2f, 0.6f)}) {
      const glm::vec3 p =
          w.x * m.positions[tri.x] + w.y * m.positions[tri.y] + w.z * m.positions[tri.z];
      const glm::vec2 t = w.x * uv[tri.x] + w.y * uv[tri.y] + w.z * uv[tri.z];
      const double d = glm::length(glm::dvec3(p) - glm::dvec3(0.3, h, 0.6));
      const double want = intensity * h / (d * d * d);
      const double got = bilinear(*irradiance, t).y;
      worst = std::max(worst, std::abs(got - want) / want);
      ++points;
    }
  }
  EXPECT_EQ(points, 8);
  EXPECT_LT(worst, 0.02);
}

// The textured room as Blender's glTF exporter wrote it: its materials, textures, images,
// samplers, nodes and meshes are all still there, unchanged but for the lightmap's additions
// (Painting's material, whose base colour uses TEXCOORD_1, takes its lightmap on TEXCOORD_2), and
// the baked file renders bit for bit as the input does.
TEST(BakeAsset, TheTexturedRoomKeepsEverythingAndRendersAsItsInput) {
  TempDir dir;
  const std::string room = std::string(PENUMBRA_SOURCE_DIR) + "/scenes/textured_room/room.glb";
  const fs::path out = dir.path() / "out";
  const auto r =
      runCli("bake " + room + " --method progressive --texel-density 5 --quiet -o " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  Expected<GltfDocument> input = readGltfDocument(room);
  ASSERT_TRUE(input.ok());
  const json& in = input->json;
  const json baked = test::readJson((out / "room.gltf").string());
  for (const char* key :
       {"images", "textures", "samplers", "materials", "nodes", "meshes", "cameras", "scenes"}) {
    ASSERT_GE(baked[key].size(), in[key].size()) << key;
    for (size_t i = 0; i < in[key].size(); ++i) {
      json got = baked[key][i];
      json want = in[key][i];
      if (std::string(key) == "materials") {
        got["extensions"].erase("PENUMBRA_lightmap");
        if (got["extensions"].empty()) got.erase("extensions");
      }
      if (std::string(key) == "meshes") {
        // The same primitives with their materials; the attributes the input had, plus one.
        ASSERT_EQ(got["primitives"].size(), want["primitives"].size());
        for (size_t p = 0; p < want["primitives"].size(); ++p) {
          EXPECT_EQ(got["primitives"][p]["material"], want["primitives"][p]["material"]);
          EXPECT_EQ(got["primitives"][p]["attributes"].size(),
                    want["primitives"][p]["attributes"].size() + 1);
          for (auto& [name, accessor] : want["primitives"][p]["attributes"].items()) {
            EXPECT_TRUE(got["primitives"][p]["attributes"].contains(name)) << name;
          }
        }
        continue;
      }
      EXPECT_EQ(got, want) << key << "[" << i << "]";
    }
  }
  EXPECT_EQ(baked["asset"]["extras"]["penumbra"]["source_generator"], in["asset"]["generator"]);
  const std::map<std::string, int> sets = lightmapSets(baked);
  EXPECT_EQ(sets.at("Painting"), 2);
  EXPECT_EQ(sets.at("Floor"), 1);
  // The image bytes the input embeds are the output's, at the same buffer views.
  Expected<GltfDocument> back = readGltfDocument((out / "room.gltf").string());
  ASSERT_TRUE(back.ok()) << back.error().describe();
  for (size_t i = 0; i < in["images"].size(); ++i) {
    const auto bytes = [](const GltfDocument& d, size_t image) {
      const json& v = d.json["bufferViews"][d.json["images"][image]["bufferView"].get<size_t>()];
      return d.buffers[v.value("buffer", size_t(0))].substr(v.value("byteOffset", size_t(0)),
                                                            v["byteLength"].get<size_t>());
    };
    EXPECT_EQ(bytes(*back, i), bytes(*input, i)) << "image " << i;
  }
  // Rendered by the path tracer, the baked file is its input.
  const std::string render =
      " --method pathtrace --spp 2 --width 96 --height 72 --seed 5 --device cpu --quiet -o ";
  const auto a = runCli("render " + room + render + (dir.path() / "a.pfm").string());
  const auto b =
      runCli("render " + (out / "room.gltf").string() + render + (dir.path() / "b.pfm").string());
  ASSERT_EQ(a.exit_code, 0) << a.output;
  ASSERT_EQ(b.exit_code, 0) << b.output;
  EXPECT_EQ(*penumbra::readFile((dir.path() / "a.pfm").string()),
            *penumbra::readFile((dir.path() / "b.pfm").string()));
}

// --lightmap-uv asset on a file whose second UV set is a lightmap layout (the Cornell box as the
// asset output writes it): the bake keeps that layout, each mesh's new lightmap UVs an affine
// image of its TEXCOORD_1, and the radiosity lightmap agrees with the path-traced one baked the
// same way.
TEST(BakeAsset, AssetLightmapUvsKeepTheirLayoutAndAgreeWithThePathTracedBake) {
  TempDir dir;
  const fs::path first = dir.path() / "first";
  ASSERT_EQ(
      runCli("bake cornell --method progressive --texel-density 20 --quiet -o " + first.string())
          .exit_code,
      0);
  const std::string asset = (first / "cornell.gltf").string();
  const auto bakeWith = [&](const std::string& method) {
    const fs::path out = dir.path() / method;
    const auto r = runCli("bake " + asset + " --method " + method +
                          " --texel-density 20 --lightmap-uv asset -o " + out.string());
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("TEXCOORD_1 of 8 of 8 meshes"), std::string::npos) << r.output;
    Expected<Image> lightmap = readImage((out / "cornell_lightmap.exr").string());
    EXPECT_TRUE(lightmap.ok());
    return lightmap.ok() ? *lightmap : Image{};
  };
  const Image reference = bakeWith("pathtrace");
  const Image got = bakeWith("progressive");
  ASSERT_EQ(got.pixels.size(), reference.pixels.size());
  double ref = 0.0, sum = 0.0, sq = 0.0;
  size_t texels = 0;
  for (size_t i = 0; i < reference.pixels.size(); ++i) {
    const double r = 0.2126 * reference.pixels[i].x + 0.7152 * reference.pixels[i].y +
                     0.0722 * reference.pixels[i].z;
    const double g = 0.2126 * got.pixels[i].x + 0.7152 * got.pixels[i].y + 0.0722 * got.pixels[i].z;
    if (r <= 0.0 && g <= 0.0) continue;
    ++texels;
    ref += r;
    sum += g;
    sq += (g - r) * (g - r);
  }
  ASSERT_GT(texels, 1000u);
  EXPECT_NEAR(sum / ref, 1.0, 0.015);
  EXPECT_LT(std::sqrt(sq / double(texels)) / (ref / double(texels)), 0.05);

  // Each mesh's lightmap UVs are one affine image of its TEXCOORD_1 (the block placed whole).
  Expected<Scene> in = loadScene(asset);
  Expected<Scene> out = loadScene((dir.path() / "progressive" / "cornell.gltf").string());
  ASSERT_TRUE(in.ok() && out.ok());
  const json doc = test::readJson((dir.path() / "progressive" / "cornell.gltf").string());
  EXPECT_EQ(doc["asset"]["extras"]["penumbra"]["lightmap"]["uv"], "asset");
  const std::map<std::string, int> sets = lightmapSets(doc);
  for (size_t m = 0; m < out->meshes.size(); ++m) {
    const Mesh& a = in->meshes[m];
    const Mesh& b = out->meshes[m];
    const std::vector<glm::vec2>& from = a.uvSet(1);
    const std::vector<glm::vec2>& to =
        b.uvSet(uint32_t(sets.at(out->materials[b.material_ids[0]].name)));
    ASSERT_EQ(a.triangles.size(), b.triangles.size());
    // The map from the first triangle with UV area, checked on every corner.
    const glm::uvec3 ta = a.triangles[0], tb = b.triangles[0];
    const glm::dvec2 a0(from[ta.x]), b0(to[tb.x]);
    const glm::dmat2 map =
        glm::dmat2(glm::dvec2(to[tb.y]) - b0, glm::dvec2(to[tb.z]) - b0) *
        glm::inverse(glm::dmat2(glm::dvec2(from[ta.y]) - a0, glm::dvec2(from[ta.z]) - a0));
    double worst = 0.0;
    for (size_t t = 0; t < a.triangles.size(); ++t) {
      for (int k = 0; k < 3; ++k) {
        const glm::dvec2 want = b0 + map * (glm::dvec2(from[a.triangles[t][k]]) - a0);
        worst = std::max(worst, glm::length(want - glm::dvec2(to[b.triangles[t][k]])));
      }
    }
    EXPECT_LT(worst * 80.0, 1e-3) << b.name;  // in texels of the 80-texel-wide atlas
  }
}

// --preview: a bake at a quarter of the density is placed in DIR/preview first; its lightmap has
// about a sixteenth of the texels and the same light.
TEST(BakeAsset, APreviewIsACoarseBakeOfTheSameLight) {
  TempDir dir;
  const fs::path out = dir.path() / "out";
  const auto r = runCli("bake cornell --method progressive --texel-density 40 --preview -o " +
                        out.string() + " --web " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("preview: "), std::string::npos) << r.output;
  for (const char* f : {"cornell.gltf", "cornell.bin", "cornell_lightmap.exr",
                        "cornell_lightmap.png", "index.html", "bake.json"}) {
    EXPECT_TRUE(fs::exists(out / f)) << f;
    EXPECT_TRUE(fs::exists(out / "preview" / f)) << f;
  }
  // The same light: the lightmaps looked up at every triangle's centroid, through each file's
  // own lightmap UVs; and about a sixteenth of the texels (the texels the lightmap triangles
  // cover, their UV area in texels: the atlases' gutters and the values' zeros do not count).
  const auto lookups = [](const fs::path& d, double* texels) {
    Expected<Image> e = readImage((d / "cornell_lightmap.exr").string());
    Expected<Scene> sc = loadScene((d / "cornell.gltf").string());
    std::vector<double> values;
    if (!e.ok() || !sc.ok()) return values;
    const std::map<std::string, int> sets =
        lightmapSets(test::readJson((d / "cornell.gltf").string()));
    *texels = 0.0;
    for (const Mesh& m : sc->meshes) {
      const std::vector<glm::vec2>& uv =
          m.uvSet(uint32_t(sets.at(sc->materials[m.material_ids[0]].name)));
      for (const glm::uvec3& t : m.triangles) {
        const glm::vec3 v = bilinear(*e, (uv[t.x] + uv[t.y] + uv[t.z]) / 3.0f);
        values.push_back(0.2126 * v.x + 0.7152 * v.y + 0.0722 * v.z);
        const glm::vec2 a = uv[t.y] - uv[t.x], b = uv[t.z] - uv[t.x];
        *texels += 0.5 * std::abs(double(a.x) * b.y - double(a.y) * b.x) * e->width * e->height;
      }
    }
    return values;
  };
  double n_full = 0.0, n_preview = 0.0;
  const std::vector<double> full = lookups(out, &n_full),
                            preview = lookups(out / "preview", &n_preview);
  ASSERT_EQ(full.size(), preview.size());
  ASSERT_GT(full.size(), 20u);
  double sum_full = 0.0, sum_preview = 0.0;
  for (size_t i = 0; i < full.size(); ++i) {
    sum_full += full[i];
    sum_preview += preview[i];
  }
  EXPECT_NEAR(sum_preview / sum_full, 1.0, 0.05);
  EXPECT_NEAR(n_preview / n_full, 1.0 / 16.0, 0.01);
  EXPECT_EQ(test::readJson((out / "preview" / "bake.json").string())["gltf"], "cornell.gltf");
}

}  // namespace
}  // namespace penumbra
