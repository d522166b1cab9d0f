// `penumbra bake`: the files it writes hold the solver's solution (glTF read back with tinygltf,
// the EXR sampled at element centroids), and bad input gives one error line, exit code 2 and no
// files.
#include "penumbra/io/image_io.h"
#include "penumbra/radiosity/matrix_radiosity.h"
#include "penumbra/radiosity/progressive.h"
#include "penumbra/scene/builtin.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <tiny_gltf.h>
#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>

namespace penumbra {
namespace {

namespace fs = std::filesystem;
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

// Copies a float VEC2/VEC3 accessor out of the model.
template <int N>
std::vector<glm::vec<N, float>> readFloats(const tinygltf::Model& model, int accessor_index) {
  const tinygltf::Accessor& a = model.accessors.at(size_t(accessor_index));
  EXPECT_EQ(a.componentType, TINYGLTF_COMPONENT_TYPE_FLOAT);
  EXPECT_EQ(a.type, N == 2 ? TINYGLTF_TYPE_VEC2 : TINYGLTF_TYPE_VEC3);
  const tinygltf::BufferView& view = model.bufferViews.at(size_t(a.bufferView));
  const tinygltf::Buffer& buffer = model.buffers.at(size_t(view.buffer));
  const size_t stride = view.byteStride ? view.byteStride : sizeof(glm::vec<N, float>);
  std::vector<glm::vec<N, float>> out(a.count);
  for (size_t i = 0; i < a.count; ++i) {
    std::memcpy(&out[i], buffer.data.data() + view.byteOffset + a.byteOffset + i * stride,
                sizeof(out[i]));
  }
  return out;
}

std::vector<uint32_t> readIndices(const tinygltf::Model& model, int accessor_index) {
  const tinygltf::Accessor& a = model.accessors.at(size_t(accessor_index));
  EXPECT_EQ(a.componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
  const tinygltf::BufferView& view = model.bufferViews.at(size_t(a.bufferView));
  const tinygltf::Buffer& buffer = model.buffers.at(size_t(view.buffer));
  std::vector<uint32_t> out(a.count);
  std::memcpy(out.data(), buffer.data.data() + view.byteOffset + a.byteOffset, 4 * a.count);
  return out;
}

glm::vec3 bilinear(const Image& image, glm::vec2 uv) {
  const float fx = uv.x * float(image.width) - 0.5f, fy = uv.y * float(image.height) - 0.5f;
  const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
  const float ax = fx - float(x0), ay = fy - float(y0);
  auto at = [&](int x, int y) {
    return image.at(std::clamp(x, 0, image.width - 1), std::clamp(y, 0, image.height - 1));
  };
  return (at(x0, y0) * (1 - ax) + at(x0 + 1, y0) * ax) * (1 - ay) +
         (at(x0, y0 + 1) * (1 - ax) + at(x0 + 1, y0 + 1) * ax) * ay;
}

// Exact float equality of two vec3 (bit patterns, so -0 and NaN are not glossed over).
bool same(const glm::vec3& a, const glm::vec3& b) {
  return std::memcmp(&a, &b, sizeof(a)) == 0;
}

TEST(Bake, CornellWritesAGltfAndLightmapsHoldingTheSolution) {
  TempDir dir;
  const fs::path out = dir.path() / "baked";  // created by bake
  const auto r =
      runCli("bake cornell --method matrix --elements 300 --lightmap-size 512 --quiet -o " +
             out.string() + " --stats " + (out / "stats.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(r.output.empty()) << r.output;
  EXPECT_EQ(listDirectory(out),
            (std::set<std::string>{"cornell.gltf", "cornell.bin", "cornell_lightmap.exr",
                                   "cornell_lightmap.png", "stats.json"}));

  // The same solve in this process (deterministic: same elements, form factors, solver).
  Expected<Scene> scene = builtinScene("cornell");
  ASSERT_TRUE(scene.ok());
  MatrixRadiosityOptions mo;
  mo.meshing.target_elements = 300;
  Expected<MatrixRadiosity> mr = buildMatrixRadiosity(*scene, mo);
  ASSERT_TRUE(mr.ok()) << mr.error().describe();
  SolveOptions so;  // bake's defaults: Gauss-Seidel, 500 iterations, 1e-6
  const SolveStats solved = mr->solve(so);
  const std::vector<glm::vec3> corners = mr->cornerRadiance();
  const size_t n = mr->elements.size();

  // Stats.
  std::ifstream stats_file(out / "stats.json");
  const nlohmann::json stats = nlohmann::json::parse(stats_file);
  EXPECT_EQ(stats["method"], "matrix");
  EXPECT_EQ(stats["device"], "cpu");
  EXPECT_EQ(stats["elements"].get<size_t>(), n);
  EXPECT_EQ(stats["iterations"].get<int>(), solved.iterations);
  EXPECT_LE(stats["residual"].get<double>(), 1e-6);
  EXPECT_EQ(stats["history"].size(), solved.history.size());
  EXPECT_GT(stats["seconds"].get<double>(), 0.0);
  EXPECT_EQ(stats["atlas"]["width"], 512);
  EXPECT_EQ(stats["atlas"]["height"], 512);

  // The glTF, loaded back with tinygltf (images are not decoded here).
  tinygltf::TinyGLTF loader;
  loader.SetImageLoader([](tinygltf::Image*, const int, std::string*, std::string*, int, int,
                           const unsigned char*, int, void*) { return true; },
                        nullptr);
  tinygltf::Model model;
  std::string err, warn;
  ASSERT_TRUE(loader.LoadASCIIFromFile(&model, &err, &warn, (out / "cornell.gltf").string()))
      << err;
  EXPECT_EQ(model.asset.version, "2.0");
  ASSERT_EQ(model.materials.size(), scene->materials.size());
  for (const tinygltf::Material& m : model.materials) {
    EXPECT_EQ(m.emissiveTexture.index, 0);
    EXPECT_EQ(m.emissiveTexture.texCoord, 1);  // the lightmap is on TEXCOORD_1
  }
  ASSERT_EQ(model.images.size(), 1u);
  EXPECT_EQ(model.images[0].uri, "cornell_lightmap.png");
  const tinygltf::Value& extras = model.asset.extras.Get("penumbra");
  ASSERT_TRUE(extras.IsObject());
  const double color_scale = extras.Get("color_0_scale").GetNumberAsDouble();
  EXPECT_GT(color_scale, 0.0);
  ASSERT_EQ(model.meshes.size(), 1u);

  // Every element appears once, with _RADIANCE equal to the solver's corner radiance, COLOR_0 its
  // clamped, scaled copy, and the EXR sampled at its centroid equal to its smooth radiance there.
  Expected<Image> exr = readImage((out / "cornell_lightmap.exr").string());
  ASSERT_TRUE(exr.ok()) << exr.error().describe();
  EXPECT_EQ(exr->width, 512);
  std::vector<bool> seen(n, false);
  size_t triangles = 0;
  std::vector<double> flat_error;
  for (const tinygltf::Primitive& p : model.meshes[0].primitives) {
    const auto positions = readFloats<3>(model, p.attributes.at("POSITION"));
    const auto radiance = readFloats<3>(model, p.attributes.at("_RADIANCE"));
    const auto color = readFloats<3>(model, p.attributes.at("COLOR_0"));
    const auto uv1 = readFloats<2>(model, p.attributes.at("TEXCOORD_1"));
    const auto uv0 = readFloats<2>(model, p.attributes.at("TEXCOORD_0"));
    const auto normals = readFloats<3>(model, p.attributes.at("NORMAL"));
    const std::vector<uint32_t> indices = readIndices(model, p.indices);
    ASSERT_EQ(uv0, uv1);  // the Cornell box has no UVs of its own
    for (size_t v = 0; v < color.size(); ++v) {
      for (int c = 0; c < 3; ++c) {
        EXPECT_FLOAT_EQ(color[v][c], std::min(1.0f, float(color_scale) * radiance[v][c]));
        EXPECT_GE(color[v][c], 0.0f);
      }
    }
    for (size_t t = 0; t < indices.size() / 3; ++t, ++triangles) {
      const glm::vec3 p0 = positions[indices[3 * t]], p1 = positions[indices[3 * t + 1]],
                      p2 = positions[indices[3 * t + 2]];
      // The element with these corners, in order.
      size_t e = n;
      for (size_t i = 0; i < n; ++i) {
        const glm::uvec3 tri = mr->elements.triangles[i];
        if (same(mr->elements.positions[tri.x], p0) && same(mr->elements.positions[tri.y], p1) &&
            same(mr->elements.positions[tri.z], p2)) {
          e = i;
          break;
        }
      }
      ASSERT_LT(e, n) << "no element with the corners of glTF triangle " << t;
      ASSERT_FALSE(seen[e]);
      seen[e] = true;
      EXPECT_EQ(normals[indices[3 * t]], mr->elements.normal[e]);
      glm::vec3 mean(0.0f);
      glm::vec2 uv(0.0f);
      for (int k = 0; k < 3; ++k) {
        EXPECT_TRUE(same(radiance[indices[3 * t + size_t(k)]], corners[3 * e + size_t(k)]))
            << "element " << e << " corner " << k;
        mean += corners[3 * e + size_t(k)] / 3.0f;
        uv += uv1[indices[3 * t + size_t(k)]] / 3.0f;
      }
      // The lightmap at the centroid: the smooth field there (bilinear on texels of the same
      // element: exact up to float rounding) ...
      const glm::vec3 sample = bilinear(*exr, uv);
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(sample[c], mean[c], 1e-4f * std::max(1.0f, mean[c]))
            << "element " << e << " channel " << c;
      }
      // ... which lies between the radiances B / pi of the element and its neighbours (the
      // corner values average them), and near the element's own.
      glm::vec3 lo = mr->radiosity[e], hi = mr->radiosity[e];
      for (size_t f = 0; f < n; ++f) {
        const glm::uvec3 a = mr->elements.triangles[e], b = mr->elements.triangles[f];
        bool shares = false;
        for (int i = 0; i < 3; ++i) {
          for (int j = 0; j < 3; ++j) shares = shares || a[i] == b[j];
        }
        if (!shares || glm::dot(mr->elements.normal[e], mr->elements.normal[f]) < 0.866f) continue;
        lo = glm::min(lo, mr->radiosity[f]);
        hi = glm::max(hi, mr->radiosity[f]);
      }
      lo /= 3.14159265f;
      hi /= 3.14159265f;
      const glm::vec3 flat = mr->radiosity[e] / 3.14159265f;
      const float peak = std::max({flat.x, flat.y, flat.z, 1e-6f});
      for (int c = 0; c < 3; ++c) {
        EXPECT_GE(sample[c], lo[c] - 1e-5f * peak) << "element " << e << " channel " << c;
        EXPECT_LE(sample[c], hi[c] + 1e-5f * peak) << "element " << e << " channel " << c;
      }
      const glm::vec3 d = glm::abs(sample - flat);
      flat_error.push_back(std::max({d.x, d.y, d.z}) / peak);
    }
  }
  EXPECT_EQ(triangles, n);
  std::sort(flat_error.begin(), flat_error.end());
  RecordProperty("median_flat_error", std::to_string(flat_error[flat_error.size() / 2]));
  EXPECT_LT(flat_error[flat_error.size() / 2], 0.15) << "median relative difference";
}

// Progressive radiosity's bake: the EXR is the solver's own lightmap (its texels are the
// elements, Wallner sec. 3), bit for bit what the same solve in this process gives; the glTF
// holds the scene's triangles with the atlas's UVs on TEXCOORD_1 and, per corner, the lightmap's
// value there.
TEST(Bake, ProgressiveWritesTheSolversOwnLightmap) {
  TempDir dir;
  const fs::path out = dir.path() / "baked";
  const auto r = runCli("bake cornell --method progressive --texel-density 40 --quiet -o " +
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

  tinygltf::TinyGLTF loader;
  loader.SetImageLoader([](tinygltf::Image*, const int, std::string*, std::string*, int, int,
                           const unsigned char*, int, void*) { return true; },
                        nullptr);
  tinygltf::Model model;
  std::string err, warn;
  ASSERT_TRUE(loader.LoadASCIIFromFile(&model, &err, &warn, (out / "cornell.gltf").string()))
      << err;
  for (const tinygltf::Material& m : model.materials) EXPECT_EQ(m.emissiveTexture.texCoord, 1);
  const ChartAtlas& atlas = pr->atlas();
  const FlatTriangles& flat = pr->triangles();
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
  for (const tinygltf::Primitive& p : model.meshes.at(0).primitives) {
    const auto positions = readFloats<3>(model, p.attributes.at("POSITION"));
    const auto radiance = readFloats<3>(model, p.attributes.at("_RADIANCE"));
    const auto uv1 = readFloats<2>(model, p.attributes.at("TEXCOORD_1"));
    const std::vector<uint32_t> indices = readIndices(model, p.indices);
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
      {"bake cornell --method nonsense -o " + out, "unknown method 'nonsense'"},
      {"bake cornell --method stochastic -o " + out, "not available"},
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
