// `render --method whitted | photons` from the command line on scenes/cornell-glass.json (a
// mirror ball and a glass ball in the Cornell box), the radiosity methods' warning about mirrors
// and glass, and bad input for the new options.
#include "penumbra/io/image_io.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>
#include <vector>

namespace penumbra {
namespace {

namespace fs = std::filesystem;
using test::readJson;
using test::runCli;
using test::TempDir;

const std::string kGlassScene =
    std::string(PENUMBRA_TEST_DATA) + "/../../scenes/cornell-glass.json";

double meanRadiance(const std::string& path) {
  Expected<Image> img = readImage(path);
  EXPECT_TRUE(img.ok()) << path;
  if (!img) return 0.0;
  double sum = 0.0;
  for (const glm::vec3& p : img->pixels) sum += double(p.x) + double(p.y) + double(p.z);
  return sum / (3.0 * double(img->pixels.size()));
}

// Whitted's image holds only direct light (and what mirrors and glass show of it): darker than
// the path tracer's. Photon mapping adds the indirect light and the caustic: its mean comes to the
// path tracer's within a few percent. Both write the stats they document (docs/cli.md).
TEST(SpecularCli, WhittedAndPhotonsRenderMirrorsAndGlass) {
  TempDir dir;
  const std::string size = " --width 48 --height 48 --device cpu --quiet";
  auto r = runCli("render " + kGlassScene + " --method whitted --spp 4" + size + " -o " +
                  dir.file("w.pfm") + " --stats " + dir.file("w.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = runCli("render " + kGlassScene +
             " --method photons --spp 4 --photons 50000 --caustic-photons 50000 --final-gather 8" +
             size + " -o " + dir.file("p.pfm") + " --stats " + dir.file("p.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = runCli("render " + kGlassScene + " --spp 256" + size + " -o " + dir.file("t.pfm"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const double w = meanRadiance(dir.file("w.pfm")), p = meanRadiance(dir.file("p.pfm")),
               t = meanRadiance(dir.file("t.pfm"));
  std::printf("cornell-glass 48x48: whitted %.4f, photons %.4f, path tracer %.4f\n", w, p, t);
  EXPECT_LT(w, 0.85 * t);  // no indirect light
  EXPECT_NEAR(p / t, 1.0, 0.05);

  const nlohmann::json ws = readJson(dir.file("w.json"));
  EXPECT_EQ(ws["method"], "whitted");
  EXPECT_EQ(ws["device"], "cpu");
  EXPECT_EQ(ws["max_depth"], 8);
  EXPECT_EQ(ws["light_samples"], 8);
  EXPECT_GE(ws["tree_rays"].get<double>(), 48.0 * 48.0 * 4.0);
  EXPECT_GT(ws["shadow_rays"].get<double>(), ws["tree_rays"].get<double>());
  EXPECT_EQ(ws["rays"].get<double>(),
            ws["tree_rays"].get<double>() + ws["shadow_rays"].get<double>());
  const nlohmann::json ps = readJson(dir.file("p.json"));
  EXPECT_EQ(ps["method"], "photons");
  EXPECT_EQ(ps["photons"]["emitted"], 50000);
  EXPECT_EQ(ps["photons"]["caustic_emitted"], 50000);
  EXPECT_GT(ps["photons"]["stored"].get<double>(), 50000.0);  // about 2 landings per photon
  EXPECT_GT(ps["photons"]["caustic_stored"].get<double>(), 1000.0);
  EXPECT_GT(ps["photons"]["photons_per_s"].get<double>(), 0.0);
  EXPECT_EQ(ps["photons"]["final_gather"], 8);
  EXPECT_GT(ps["gather_rays"].get<double>(), 0.0);
}

// The methods without specular transport say what they see instead, once per material.
TEST(SpecularCli, RadiosityMethodsWarnAboutTheirStandIn) {
  for (const char* method : {"progressive", "matrix"}) {
    const auto r = runCli("render " + kGlassScene + " --method " + method + " --dry-run");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find(std::string("material 'glass' is glass (ior 1.5): --method ") + method +
                            " sees a diffuse surface of reflectance (0.04, 0.04, 0.04)"),
              std::string::npos)
        << r.output;
    EXPECT_NE(r.output.find("material 'mirror' is a mirror"), std::string::npos) << r.output;
  }
  const auto r = runCli("render " + kGlassScene + " --method whitted --dry-run");
  EXPECT_EQ(r.output.find("diffuse surface"), std::string::npos) << r.output;
}

TEST(SpecularCli, InfoNamesMirrorsAndGlass) {
  const auto r = runCli("info " + kGlassScene);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("glass, ior 1.5, filter (1, 1, 1)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("mirror (0.95, 0.95, 0.95)"), std::string::npos) << r.output;
}

TEST(SpecularCli, BadOptionsGiveOneErrorLineAndNoOutput) {
  TempDir dir;
  const std::string out = " -o " + dir.file("out.png");
  const std::pair<std::string, std::string> cases[] = {
      {"render cornell --light-samples 4",
       "--light-samples: applies to --method whitted and photons"},
      {"render cornell --method whitted --photons 10", "--photons: applies to --method photons"},
      {"render cornell --method matrix --final-gather 4", "--final-gather"},
      {"render cornell --method photons --gather-radius -1", "--gather-radius"},
      {"render cornell --method photons --gather-count 0", "--gather-count"},
      {"render cornell --method photons --photons 0", "--photons"},
      {"render cornell --method whitted --max-depth 65", "--max-depth"},
      {"render cornell --method whitted --light-samples 2000", "--light-samples"},
      {"render cornell --method photons --photons 4000000000", "needs"},
      {"render cornell --method whitted --elements 100", "--elements"},
      {"render cornell --method photons --output-quantity illuminance",
       "--output-quantity: applies to --method pathtrace, matrix and progressive only"},
  };
  for (const auto& [args, expect] : cases) {
    const auto r = runCli(args + out);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
    EXPECT_NE(r.output.find(expect), std::string::npos) << args << "\n" << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << args << "\n" << r.output;
  }
  EXPECT_TRUE(fs::is_empty(dir.path()));
}

}  // namespace
}  // namespace penumbra
