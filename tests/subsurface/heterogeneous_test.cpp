// Heterogeneous media for the light propagation volumes (scene/heterogeneous_media.h): the grid
// file round-trips and refuses bad files with the file and place; scenes take a grid or a
// pattern in the subsurface block; a uniform grid gives the homogeneous medium's picture and the
// marble veins change it where they run.
#include "penumbra/io/scene_io.h"
#include "penumbra/scene/heterogeneous_media.h"
#include "penumbra/scene/media.h"
#include "penumbra/subsurface/lpv.h"
#include "support/test_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <string>

namespace penumbra {
namespace {

using test::TempDir;

MediumGrid smallGrid() {
  MediumGrid g;
  g.size = glm::ivec3(3, 2, 2);
  for (int i = 0; i < 12; ++i) {
    MediumSample s;
    s.sigma_a = glm::dvec3(0.001 * i, 0.002, 0.003) * 1e3;
    s.sigma_s_prime = glm::dvec3(1.0, 2.0, 3.0 + i) * 1e3;
    s.g = 0.05 * i;
    g.samples.push_back(s);
  }
  return g;
}

void writeRaw(const std::string& path, const std::string& header, const std::vector<float>& v) {
  std::ofstream f(path, std::ios::binary);
  f << header;
  f.write(reinterpret_cast<const char*>(v.data()), std::streamsize(v.size() * sizeof(float)));
}

TEST(HeterogeneousMedium, GridFileRoundTripsAndInterpolates) {
  TempDir dir;
  const MediumGrid g = smallGrid();
  ASSERT_TRUE(writeMediumGrid(dir.file("m.pmed"), g).ok());
  Expected<MediumGrid> back = readMediumGrid(dir.file("m.pmed"));
  ASSERT_TRUE(back.ok()) << back.error().describe();
  ASSERT_EQ(back->size, g.size);
  for (size_t i = 0; i < g.samples.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(back->samples[i].sigma_a[c], g.samples[i].sigma_a[c], 1e-4);
      EXPECT_NEAR(back->samples[i].sigma_s_prime[c], g.samples[i].sigma_s_prime[c], 1e-3);
    }
    EXPECT_NEAR(back->samples[i].g, g.samples[i].g, 1e-6);
  }
  // At a sample's centre its own value; halfway between two along x their mean.
  const MediumSample centre = back->at(glm::dvec3(0.5 / 3.0, 0.25, 0.25));
  EXPECT_NEAR(centre.sigma_s_prime.z, 3000.0, 1e-3);
  const MediumSample between = back->at(glm::dvec3(1.0 / 3.0, 0.25, 0.25));
  EXPECT_NEAR(between.sigma_s_prime.z, 3500.0, 1e-3);
  EXPECT_NEAR(between.g, 0.025, 1e-6);
}

TEST(HeterogeneousMedium, BadGridFilesNameTheFileAndPlace) {
  TempDir dir;
  const std::vector<float> one = {0.1f, 0.1f, 0.1f, 1.0f, 1.0f, 1.0f, 0.0f};
  std::vector<float> nan = one;
  nan[2] = std::numeric_limits<float>::quiet_NaN();
  std::vector<float> bad_g = one;
  bad_g[6] = 1.5f;
  const struct {
    const char* name;
    std::string header;
    std::vector<float> data;
    const char* place;
  } cases[] = {
      {"magic.pmed", "penumbra-grid 1\n1 1 1\n", one, "line 1"},
      {"dims.pmed", "penumbra-medium 1\n1 1\n", one, "line 2"},
      {"huge.pmed", "penumbra-medium 1\n100000 100000 100000\n", one, "line 2"},
      {"short.pmed", "penumbra-medium 1\n2 1 1\n", one, "data"},
      {"nan.pmed", "penumbra-medium 1\n1 1 1\n", nan, "sample (0, 0, 0) value 2"},
      {"g.pmed", "penumbra-medium 1\n1 1 1\n", bad_g, "sample (0, 0, 0) g"},
  };
  for (const auto& c : cases) {
    writeRaw(dir.file(c.name), c.header, c.data);
    EXPECT_TRUE(test::errorNames(readMediumGrid(dir.file(c.name)), c.name, c.place)) << c.name;
  }
  EXPECT_TRUE(test::errorNames(readMediumGrid(dir.file("missing.pmed")), "missing.pmed", ""));
}

// A scene: a 2 cm marble cube under a directional light from above, its medium given in the
// JSON scene file.
std::string cubeScene(const TempDir& dir, const std::string& subsurface) {
  dir.write("cube.obj",
            "v 0 0 0\nv 0.02 0 0\nv 0.02 0.02 0\nv 0 0.02 0\nv 0 0 0.02\nv 0.02 0 0.02\n"
            "v 0.02 0.02 0.02\nv 0 0.02 0.02\n"
            "f 1 4 3\nf 1 3 2\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 4 8 7\nf 4 7 3\n"
            "f 1 5 8\nf 1 8 4\nf 2 3 7\nf 2 7 6\n");
  return dir.write("cube.json", R"({"materials": {"m": {"subsurface": )" + subsurface + R"(}},
  "meshes": [{"file": "cube.obj", "material": "m"}],
  "lights": [{"type": "directional", "direction": [0.3, -1, 0.2], "irradiance": [2, 2, 2]}],
  "camera": {"position": [0.01, 0.06, 0.05], "look_at": [0.01, 0.01, 0.01], "fov_deg": 40}})");
}

Image lpvImage(const std::string& path) {
  Expected<Scene> scene = loadScene(path);
  EXPECT_TRUE(scene.ok()) << scene.error().describe();
  Expected<LpvSolver> solver = LpvSolver::build(*scene, LpvOptions{});
  EXPECT_TRUE(solver.ok());
  EXPECT_TRUE(solver->update(*scene).ok());
  return solver->render(*scene, *scene->camera, 48, 48, 1, 0);
}

TEST(HeterogeneousMedium, ScenesTakeGridsAndPatterns) {
  TempDir dir;
  // A uniform grid of marble's coefficients: the homogeneous picture.
  const Subsurface marble = *subsurfacePreset("marble");
  MediumGrid uniform;
  uniform.size = glm::ivec3(4, 4, 4);
  uniform.samples.assign(64, MediumSample{marble.sigma_a, marble.sigma_s_prime, 0.0});
  ASSERT_TRUE(writeMediumGrid(dir.file("uniform.pmed"), uniform).ok());
  const Image homogeneous = lpvImage(cubeScene(dir, R"("marble")"));
  const Image gridded = lpvImage(cubeScene(dir, R"({"preset": "marble", "grid": "uniform.pmed"})"));
  const Image veins = lpvImage(cubeScene(dir, R"({"preset": "marble", "pattern": "veins"})"));
  double h = 0.0, worst = 0.0, v = 0.0;
  size_t lit = 0, changed = 0;
  for (size_t i = 0; i < homogeneous.pixels.size(); ++i) {
    const double a = homogeneous.pixels[i].y, b = gridded.pixels[i].y, c = veins.pixels[i].y;
    if (!(a > 0.0)) continue;
    ++lit;
    h += a;
    v += c;
    worst = std::max(worst, std::abs(b / a - 1.0));
    changed += std::abs(c / a - 1.0) > 0.05;
  }
  std::printf(
      "cube: %zu lit pixels; uniform grid within %.2e of the homogeneous picture; veins "
      "change %zu pixels by over 5%%, mean %.3f of it\n",
      lit, worst, changed, v / h);
  EXPECT_GT(lit, 500u);
  EXPECT_LT(worst, 1e-4);  // the grid's float32 per-millimetre coefficients
  EXPECT_GT(changed, lit / 10);
  EXPECT_LT(v, h);  // the veins absorb

  // Refused, with the key path.
  const struct {
    const char* block;
    const char* place;
  } bad[] = {{R"({"preset": "marble", "pattern": "swirls"})", "subsurface.pattern"},
             {R"({"preset": "marble", "grid": "nothere.pmed"})", "nothere.pmed"},
             {R"({"preset": "marble", "grid": "uniform.pmed", "pattern": "veins"})", "subsurface"}};
  for (const auto& b : bad) {
    const std::string path = cubeScene(dir, b.block);
    Expected<Scene> s = loadScene(path);
    ASSERT_FALSE(s.ok()) << b.block;
    EXPECT_NE(s.error().describe().find(b.place), std::string::npos) << s.error().describe();
  }
}

}  // namespace
}  // namespace penumbra
