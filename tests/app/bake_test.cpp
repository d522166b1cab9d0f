// `penumbra bake`: the files it writes hold the solver's solution (glTF read back with the reader,
// the EXR sampled at element centroids), and bad input gives one error line, exit code 2 and no
// files.
#include "penumbra/io/gltf/gltf_accessor.h"
#include "penumbra/io/gltf/gltf_asset.h"
#include "penumbra/io/image_io.h"
#include "penumbra/radiosity/matrix_radiosity.h"
#include "penumbra/radiosity/progressive.h"
#include "penumbra/radiosity/texel_path_trace.h"
#include "penumbra/scene/builtin.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <set>

namespace penumbra {
namespace {

namespace fs = std::filesystem;
using test::bilinear;
using test::runCli;
using test::TempDir;

size_t lineCount(const std::string& s) {
  return size_t(std::count(s.begin(), s.end(), '\n')) + (!s.empty() && s.back() != '\n');
}

std::set<std::string> listDirectory(const fs::path& dir) {
  std::set<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.insert(e.path().filename().string());
  return names;
}

// Copies a float VEC2/VEC3 accessor out of the document.
template <int N>
std::vector<glm::vec<N, float>> readFloats(GltfAsset& asset, int accessor_index) {
  Expected<AccessorView> a = readAccessor(asset, accessor_index, "ANY", "test");
  EXPECT_TRUE(a.ok()) << a.error().describe();
  if (!a) return {};
  EXPECT_EQ(a->component_type, kGltfFloat);
  EXPECT_EQ(a->components, N);
  std::vector<glm::vec<N, float>> out(a->count);
  for (size_t i = 0; i < a->count; ++i) {
    for (int c = 0; c < N; ++c) out[i][c] = float(a->component(i, c));
  }
  return out;
}

std::vector<uint32_t> readIndices(GltfAsset& asset, int accessor_index) {
  Expected<AccessorView> a = readAccessor(asset, accessor_index, "indices", "test");
  EXPECT_TRUE(a.ok()) << a.error().describe();
  if (!a) return {};
  EXPECT_EQ(a->component_type, kGltfUnsignedInt);
  std::vector<uint32_t> out(a->count);
  for (size_t i = 0; i < a->count; ++i) out[i] = a->index(i);
  return out;
}

// Exact float equality of two vec3 (bit patterns, so -0 and NaN are not glossed over).
bool same(const glm::vec3& a, const glm::vec3& b) {
  return std::memcmp(&a, &b, sizeof(a)) == 0;
}

// The baked glTF holds every face of the atlas once: the front of each triangle as in the scene,
// the back (two-sided materials) wound the other way, with the atlas's UVs on TEXCOORD_1 and, per
// corner, the lightmap's bilinear value there.
void expectFacesOfTheAtlas(GltfAsset& model, const ChartAtlas& atlas, const FlatTriangles& flat,
                           const Image& lightmap) {
  // Every face once: the front of each triangle as in the scene, the back (two-sided
  // materials) wound the other way.
  std::vector<int32_t> face_of(2 * flat.triangles.size(), -1);
  size_t faces = 0;
  for (size_t f = 0; f < atlas.faces.size(); ++f) {
    if (atlas.charts.face_chart[f] < 0) continue;
    face_of[2 * atlas.faces[f].triangle + (atlas.faces[f].back ? 1 : 0)] = int32_t(f);
    ++faces;
  }
  std::vector<bool> seen(face_of.size(), false);
  for (const nlohmann::json& p : model.json()["meshes"][0]["primitives"]) {
    const auto positions = readFloats<3>(model, p["attributes"]["POSITION"].get<int>());
    const auto radiance = readFloats<3>(model, p["attributes"]["_RADIANCE"].get<int>());
    const auto uv1 = readFloats<2>(model, p["attributes"]["TEXCOORD_1"].get<int>());
    const std::vector<uint32_t> indices = readIndices(model, p["indices"].get<int>());
    for (size_t t = 0; t < indices.size() / 3; ++t) {
      // The scene face with these corners.
      size_t found = face_of.size();
      const int order[2][3] = {{0, 1, 2}, {0, 2, 1}};
      for (size_t k = 0; k < flat.triangles.size(); ++k) {
        const glm::uvec3 tri = flat.triangles[k];
        for (int back = 0; back < 2; ++back) {
          bool all = true;
          for (int j = 0; j < 3; ++j) {
            all = all &&
                  same(flat.positions[tri[order[back][j]]], positions[indices[3 * t + size_t(j)]]);
          }
          if (all) found = 2 * k + size_t(back);
        }
      }
      ASSERT_LT(found, face_of.size());
      ASSERT_GE(face_of[found], 0);
      EXPECT_FALSE(seen[found]);
      seen[found] = true;
      const size_t f = size_t(face_of[found]);
      for (int j = 0; j < 3; ++j) {
        const uint32_t v = indices[3 * t + size_t(j)];
        EXPECT_EQ(uv1[v], atlas.uvs[3 * f + size_t(order[found % 2][j])]);
        // The corner value is the lightmap's bilinear lookup there.
        const glm::vec3 expect = bilinear(lightmap, uv1[v]);
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(radiance[v][c], expect[c], 1e-5f * (1 + expect[c]));
      }
    }
  }
  EXPECT_EQ(size_t(std::count(seen.begin(), seen.end(), true)), faces);
}

// Matrix radiosity's bake: the lightmap is the chart atlas's (the layout every method bakes to),
// holding the clusters' solution interpolated to its texels, bit for bit what the same solve in
// this process gives; the glTF holds the scene's faces with the atlas's UVs.
TEST(Bake, CornellWritesAGltfAndLightmapsHoldingTheSolution) {
  TempDir dir;
  const fs::path out = dir.path() / "baked";
  const auto r = runCli(
      "bake cornell --method matrix --elements 300 --lightmap-size 512 --gltf emissive "
      "--quiet -o " +
      out.string() + " --stats " + (out / "stats.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(r.output.empty()) << r.output;
  EXPECT_EQ(listDirectory(out),
            (std::set<std::string>{"cornell.gltf", "cornell.bin", "cornell_lightmap.exr",
                                   "cornell_lightmap.png", "stats.json"}));

  // The same solve in this process (deterministic: same atlas, cut, form factors, solver).
  Expected<Scene> scene = builtinScene("cornell");
  ASSERT_TRUE(scene.ok());
  MatrixRadiosityOptions mo;
  mo.elements = 300;
  mo.lightmap.size = 512;
  Expected<MatrixRadiosity> mr = buildMatrixRadiosity(*scene, mo);
  ASSERT_TRUE(mr.ok()) << mr.error().describe();
  SolveOptions so;  // bake's defaults: Gauss-Seidel, 500 iterations, 1e-6
  const SolveStats solved = mr->solve(so);
  const Image lightmap = mr->radianceImage();
  EXPECT_LE(mr->surface.atlas.width, 512);
  EXPECT_LE(mr->surface.atlas.height, 512);

  std::ifstream stats_file(out / "stats.json");
  const nlohmann::json stats = nlohmann::json::parse(stats_file);
  EXPECT_EQ(stats["method"], "matrix");
  EXPECT_EQ(stats["device"], "cpu");
  EXPECT_EQ(stats["elements"].get<size_t>(), mr->size());
  EXPECT_EQ(stats["lightmap_elements"].get<size_t>(), mr->surface.elementCount());
  EXPECT_EQ(stats["iterations"].get<int>(), solved.iterations);
  EXPECT_LE(stats["residual"].get<double>(), 1e-6);
  EXPECT_EQ(stats["history"].size(), solved.history.size());
  EXPECT_GT(stats["seconds"].get<double>(), 0.0);
  EXPECT_EQ(stats["atlas"]["width"], mr->surface.atlas.width);
  EXPECT_EQ(stats["atlas"]["height"], mr->surface.atlas.height);

  Expected<Image> exr = readImage((out / "cornell_lightmap.exr").string());
  ASSERT_TRUE(exr.ok()) << exr.error().describe();
  ASSERT_EQ(exr->width, lightmap.width);
  ASSERT_EQ(exr->height, lightmap.height);
  size_t differ = 0;
  for (size_t i = 0; i < lightmap.pixels.size(); ++i) {
    if (!same(exr->pixels[i], lightmap.pixels[i]) && differ++ < 5) {
      std::printf("%zu: %g %g\n", i, exr->pixels[i].x, lightmap.pixels[i].x);
    }
  }
  EXPECT_EQ(differ, 0u);

  Expected<GltfAsset> model = GltfAsset::open((out / "cornell.gltf").string(), {});
  ASSERT_TRUE(model.ok()) << model.error().describe();
  const nlohmann::json& doc = model->json();
  EXPECT_EQ(doc["asset"]["version"], "2.0");
  ASSERT_EQ(doc["materials"].size(), scene->materials.size());
  for (const nlohmann::json& m : doc["materials"]) {
    EXPECT_EQ(m["emissiveTexture"]["index"], 0);
    EXPECT_EQ(m["emissiveTexture"]["texCoord"], 1);  // the lightmap is on TEXCOORD_1
  }
  ASSERT_EQ(doc["images"].size(), 1u);
  EXPECT_EQ(doc["images"][0]["uri"], "cornell_lightmap.png");
  const nlohmann::json& extras = doc["asset"]["extras"]["penumbra"];
  ASSERT_TRUE(extras.is_object());
  const double color_scale = extras["color_0_scale"].get<double>();
  EXPECT_GT(color_scale, 0.0);
  for (const nlohmann::json& p : doc["meshes"][0]["primitives"]) {
    const auto radiance = readFloats<3>(*model, p["attributes"]["_RADIANCE"].get<int>());
    const auto color = readFloats<3>(*model, p["attributes"]["COLOR_0"].get<int>());
    for (size_t v = 0; v < color.size(); ++v) {
      for (int c = 0; c < 3; ++c) {
        EXPECT_FLOAT_EQ(color[v][c], std::min(1.0f, float(color_scale) * radiance[v][c]));
        EXPECT_GE(color[v][c], 0.0f);
      }
    }
  }
  expectFacesOfTheAtlas(*model, mr->surface.atlas, mr->surface.flat, lightmap);
}

// Progressive radiosity's bake: the EXR is the solver's own lightmap (its texels are the
// elements, Wallner sec. 3), bit for bit what the same solve in this process gives; the glTF
// holds the scene's triangles with the atlas's UVs on TEXCOORD_1 and, per corner, the lightmap's
// value there.
TEST(Bake, ProgressiveWritesTheSolversOwnLightmap) {
  TempDir dir;
  const fs::path out = dir.path() / "baked";
  const auto r = runCli(
      "bake cornell --method progressive --texel-density 40 --gltf emissive "
      "--quiet -o " +
      out.string() + " --stats " + (out / "stats.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(listDirectory(out),
            (std::set<std::string>{"cornell.gltf", "cornell.bin", "cornell_lightmap.exr",
                                   "cornell_lightmap.png", "stats.json"}));
  Expected<Scene> scene = builtinScene("cornell");
  ASSERT_TRUE(scene.ok());
  ProgressiveOptions po;
  po.atlas.texel_density = 40.0;
  po.max_iterations = 500;
  po.convergence = 1e-3;
  Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(*scene, po);
  ASSERT_TRUE(pr.ok()) << pr.error().describe();
  const ProgressiveStats st = pr->solve();
  ASSERT_TRUE(st.converged);
  const Image lightmap = pr->radianceImage();

  std::ifstream stats_file(out / "stats.json");
  const nlohmann::json stats = nlohmann::json::parse(stats_file);
  EXPECT_EQ(stats["method"], "progressive");
  EXPECT_EQ(stats["elements"].get<size_t>(), pr->elementCount());
  EXPECT_EQ(stats["iterations"].get<int>(), st.total_iterations);
  EXPECT_LE(stats["unshot_fraction"].get<double>(), 1e-3);

  Expected<Image> exr = readImage((out / "cornell_lightmap.exr").string());
  ASSERT_TRUE(exr.ok()) << exr.error().describe();
  ASSERT_EQ(exr->width, lightmap.width);
  ASSERT_EQ(exr->height, lightmap.height);
  size_t differ = 0;
  for (size_t i = 0; i < lightmap.pixels.size(); ++i)
    differ += !same(exr->pixels[i], lightmap.pixels[i]);
  EXPECT_EQ(differ, 0u);

  Expected<GltfAsset> model = GltfAsset::open((out / "cornell.gltf").string(), {});
  ASSERT_TRUE(model.ok()) << model.error().describe();
  for (const nlohmann::json& m : model->json()["materials"]) {
    EXPECT_EQ(m["emissiveTexture"]["texCoord"], 1);
  }
  expectFacesOfTheAtlas(*model, pr->atlas(), pr->triangles(), lightmap);
}
TEST(Bake, BadInputGivesOneErrorLineExitCode2AndNoFiles) {
  TempDir dir;
  const std::string file = dir.write("file.txt", "not a directory\n");
  const std::string out = dir.file("out");
  struct BadCase {
    std::string args, expect;
  };
  const std::vector<BadCase> cases = {
      {"bake " + dir.file("missing.obj") + " -o " + out, "missing.obj"},
      {"bake nosuchscene -o " + out, "unknown scene"},
      {"bake cornell -o " + file, "not a directory"},
      {"bake cornell -o " + file + "/sub", "not a directory"},
      {"bake cornell -o /proc/penumbra-bake-test", "cannot create the directory"},
      {"bake cornell --elements 0 -o " + out, "--elements"},
      {"bake cornell --method nonsense -o " + out, "unknown --method 'nonsense'"},
      {"bake cornell --method stochastic --shooters 0 -o " + out, "--shooters"},
      {"bake cornell --method stochastic --time-limit -1 -o " + out, "--time-limit"},
      {"bake cornell --method photons -o " + out, "unknown --method"},
      {"bake cornell --method progressive --tolerance 2 -o " + out, "--tolerance"},
      {"bake cornell --method progressive --resume " + dir.file("none.checkpoint") + " -o " + out,
       "none.checkpoint"},
      {"bake cornell --method progressive --resume " + file + " -o " + out, "not a Penumbra"},
      {"bake cornell --method matrix --resume " + file + " -o " + out, "--resume"},
      {"bake cornell --solver sor -o " + out, "--solver"},
      {"bake cornell --texel-density -5 -o " + out, "--texel-density"},
      {"bake cornell --texel-density 1e9 --elements 10 -o " + out, "--texel-density"},
      {"bake cornell --lightmap-size 4 -o " + out, "--lightmap-size"},
      {"bake cornell --tolerance -1 -o " + out, "--tolerance"},
      {"bake cornell -o " + out + " --stats " + dir.file("nodir/s.json"), "does not exist"},
      {"bake -o " + out, "scene"},
  };
  for (const BadCase& c : cases) {
    const auto r = runCli(c.args);
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.output;
    EXPECT_EQ(lineCount(r.output), 1u) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find("error"), std::string::npos) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.expect), std::string::npos) << c.args << "\n" << r.output;
  }
  // Nothing was written, not even the output directory.
  EXPECT_EQ(listDirectory(dir.path()), (std::set<std::string>{"file.txt"}));
}

}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {

double lum(const glm::dvec3& c) {
  return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
}

// The path-traced lightmap (radiosity/texel_path_trace.h) in the furnace: every texel's
// radiosity is the closed form B = E / (1 - rho) = 2 pi (radiance 2), within the texel's own
// stopping rule.
TEST(Bake, PathTracedTexelsGiveTheFurnacesClosedForm) {
  Expected<Scene> furnace = builtinScene("furnace");
  ASSERT_TRUE(furnace.ok());
  Expected<RadiositySurface> surface =
      RadiositySurface::build(*furnace, ChartAtlasOptions{.texel_density = 4.0}, true);
  ASSERT_TRUE(surface.ok()) << surface.error().describe();
  TexelPathTraceOptions o;
  o.target_error = 0.01;
  TexelPathTraceStats st;
  Expected<std::vector<glm::dvec3>> b = pathTraceTexels(*furnace, *surface, o, &st);
  ASSERT_TRUE(b.ok()) << b.error().describe();
  const double exact = 2.0 * std::numbers::pi;
  // The inner faces (those that emit); the outer ones see nothing and stay black.
  double mean = 0.0, worst = 0.0;
  size_t inner = 0;
  for (size_t e = 0; e < b->size(); ++e) {
    if (surface->emission[e] == glm::dvec3(0.0)) {
      EXPECT_LT(lum((*b)[e]), 1e-9 * exact);
      continue;
    }
    ++inner;
    mean += lum((*b)[e]);
    worst = std::max(worst, std::abs(lum((*b)[e]) / exact - 1.0));
  }
  ASSERT_GT(inner, 100u);
  EXPECT_NEAR(mean / double(inner) / exact, 1.0, 0.005);
  EXPECT_LT(worst, 0.05);  // 1% standard error: 5 sigma over a few hundred texels
  EXPECT_GE(st.mean_samples, 64.0);
}

// The reference the radiosity bakes are measured against: the Cornell box baked at 20 texels/m
// by progressive and by matrix radiosity at their defaults agrees with the path-traced bake of the
// same atlas within 5% RMS over the lightmap's texels and 1.5% in the mean (measured: 2.3% and
// 0.2%; docs/performance.md).
TEST(Bake, RadiosityBakesAgreeWithThePathTracedLightmap) {
  TempDir dir;
  const auto bakeWith = [&](const std::string& method) {
    const fs::path out = dir.path() / method;
    const auto r = runCli("bake cornell --method " + method +
                          " --texel-density 20 --gltf emissive --quiet -o " + out.string());
    EXPECT_EQ(r.exit_code, 0) << r.output;
    Expected<Image> lightmap = readImage((out / "cornell_lightmap.exr").string());
    EXPECT_TRUE(lightmap.ok());
    return lightmap.ok() ? *lightmap : Image{};
  };
  const Image reference = bakeWith("pathtrace");
  for (const char* method : {"progressive", "matrix"}) {
    const Image lightmap = bakeWith(method);
    ASSERT_EQ(lightmap.pixels.size(), reference.pixels.size()) << method;
    double ref = 0.0, got = 0.0, sq = 0.0;
    size_t texels = 0;
    for (size_t i = 0; i < reference.pixels.size(); ++i) {
      const double r = lum(glm::dvec3(reference.pixels[i])),
                   g = lum(glm::dvec3(lightmap.pixels[i]));
      if (r <= 0.0 && g <= 0.0) continue;  // outside every chart
      ++texels;
      ref += r;
      got += g;
      sq += (g - r) * (g - r);
    }
    ASSERT_GT(texels, 1000u);
    EXPECT_NEAR(got / ref, 1.0, 0.015) << method;
    EXPECT_LT(std::sqrt(sq / double(texels)) / (ref / double(texels)), 0.05) << method;
  }
}

// End to end: `bake --method pathtrace` writes what every bake writes, with its stopping rule's
// figures in the stats.
TEST(Bake, PathTraceBakeWritesTheReferenceLightmap) {
  TempDir dir;
  const fs::path out = dir.path() / "baked";
  const auto r = runCli(
      "bake cornell --method pathtrace --texel-density 10 --texel-samples 512 "
      "--tolerance 0.05 --quiet -o " +
      out.string() + " --stats " + (out / "stats.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(listDirectory(out),
            (std::set<std::string>{"cornell.gltf", "cornell.bin", "cornell_lightmap.exr",
                                   "cornell_lightmap.png", "stats.json"}));
  std::ifstream stats_file(out / "stats.json");
  const nlohmann::json stats = nlohmann::json::parse(stats_file);
  EXPECT_EQ(stats["method"], "pathtrace");
  EXPECT_GE(stats["samples_per_texel"].get<double>(), 64.0);
  EXPECT_LE(stats["samples_per_texel"].get<double>(), 512.0);
  EXPECT_EQ(stats["max_samples"].get<int>(), 512);
  // A scene's render settings (samples per pixel) do not become the texels' cap.
  nlohmann::json scene = test::readJson(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/cornell.json");
  for (auto& mesh : scene["meshes"]) {
    mesh["file"] = std::string(PENUMBRA_SOURCE_DIR) + "/scenes/" + mesh["file"].get<std::string>();
  }
  scene["settings"] = {{"pathtrace", {{"spp", 8}}}};
  const std::string with_settings = dir.write("c.json", scene.dump());
  const auto set =
      runCli("bake " + with_settings + " --method pathtrace --texel-density 5 --quiet -o " +
             (dir.path() / "b3").string() + " --stats " + (dir.path() / "s3.json").string());
  ASSERT_EQ(set.exit_code, 0) << set.output;
  EXPECT_EQ(test::readJson((dir.path() / "s3.json").string())["max_samples"].get<int>(), 4096);
  // Options the method does not take are refused with the methods that do.
  const auto bad = runCli("bake cornell --method pathtrace --iterations 5 --quiet -o " +
                          (dir.path() / "b2").string());
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("--iterations"), std::string::npos) << bad.output;
}

}  // namespace
}  // namespace penumbra
