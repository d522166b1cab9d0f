// The lighting designer's side of the command line: `penumbra info` on a manufacturer's file
// (its flux against the stated one, the polar plot), and `render --work-plane` /
// `--output-quantity illuminance` on the office scene (six luminaires in an array), where the
// work plane's figures from progressive and matrix radiosity and from the path tracer agree.
#include "penumbra/io/image_io.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace penumbra {
namespace {

using test::runCli;
using test::TempDir;

using test::readJson;

TEST(LightingDesign, InfoShowsTheFluxAgainstTheStatedOneAndWritesThePolarPlot) {
  TempDir dir;
  const std::string plot = dir.file("ldc.png");
  const test::CliResult r =
      runCli("info " + test::dataPath("photometry/sample_isym1.ldt") + " --plot " + plot);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("lm integrated from the distribution, 4828 lm stated (+0.17%)"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("symmetry 1"), std::string::npos) << r.output;
  Expected<Image> image = readImage(plot);
  ASSERT_TRUE(image.ok()) << image.error().describe();
  // Both planes' curves are drawn: strongly red and strongly blue pixels.
  int red = 0, blue = 0;
  for (const glm::vec3& p : image->pixels) {
    red += p.x > 0.5f && p.y < 0.2f && p.z < 0.2f;
    blue += p.z > 0.5f && p.x < 0.2f;
  }
  EXPECT_GT(red, 200);
  EXPECT_GT(blue, 200);
}

TEST(LightingDesign, BadPhotometricFilesGiveOneErrorLineWithTheLine) {
  TempDir dir;
  const std::string bad = dir.write("truncated.ldt", "Company\n1\n4\n24\n15\n");
  const std::string plot = dir.file("ldc.png");
  const test::CliResult r = runCli("info " + bad + " --plot " + plot);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find(bad + ": line"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(plot));
  const test::CliResult s = runCli("info cornell --plot " + plot);
  EXPECT_EQ(s.exit_code, 2) << s.output;
}

TEST(LightingDesign, OfficeWorkPlaneAgreesBetweenRadiosityAndThePathTracer) {
  TempDir dir;
  const std::string scene = std::string(PENUMBRA_SOURCE_DIR) + "/scenes/office.json";
  auto work_plane = [&](const std::string& method, const std::string& extra) {
    const std::string stats = dir.file(method + ".json"), csv = dir.file(method + ".csv");
    const test::CliResult r =
        runCli("render " + scene + " --method " + method + " --width 96 --height 64 --spp 1 " +
               "--work-plane 0.75 --grid-spacing 0.5 --grid-margin 0.5 --grid-csv " + csv +
               " --stats " + stats + " -o " + dir.file(method + ".png") + " " + extra);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    std::ifstream in(csv);
    std::string line;
    int rows = 0;
    while (std::getline(in, line)) rows += !line.empty() && line[0] != '#' && line[0] != 'x';
    EXPECT_EQ(rows, 6 * 8);  // 3 m x 4 m inside the margin at 0.5 m
    return readJson(stats)["illuminance"]["work_plane"];
  };
  const nlohmann::json radiosity = work_plane("progressive", "");
  const nlohmann::json traced = work_plane("pathtrace", "");
  const nlohmann::json matrix = work_plane("matrix", "--elements 2000");
  const double e_r = radiosity["total"]["average_lux"], e_p = traced["total"]["average_lux"];
  const double u0 = radiosity["total"]["uniformity_u0"];
  std::printf("office work plane: radiosity %.1f lx, path tracer %.1f lx, U0 %.2f\n", e_r, e_p, u0);
  const double e_m = matrix["total"]["average_lux"];
  std::printf("office work plane: matrix radiosity %.1f lx\n", e_m);
  EXPECT_NEAR(e_r / e_p, 1.0, 0.03);
  EXPECT_NEAR(e_m / e_p, 1.0, 0.03);  // the luminaires enter matrix radiosity as its direct term
  // The same delta-light term on both.
  EXPECT_NEAR(double(radiosity["direct"]["average_lux"]), double(traced["direct"]["average_lux"]),
              1e-6 * e_r);
  EXPECT_GT(e_r, 300.0);  // six 2000 lm downlights over 20 m^2
  EXPECT_GT(u0, 0.5);
  EXPECT_LE(u0, 1.0);
}

TEST(LightingDesign, DeskSurfaceGridAgreesBetweenRadiosityAndThePathTracer) {
  // --grid-surface: points on the desk's faces (a 1.2 x 0.75 x 0.72 m box; its bottom face lies
  // on the floor, in the dark), area-weighted.
  TempDir dir;
  const std::string scene = std::string(PENUMBRA_SOURCE_DIR) + "/scenes/office.json";
  auto desk = [&](const std::string& method) {
    const std::string stats = dir.file(method + "-desk.json");
    const test::CliResult r =
        runCli("render " + scene + " --method " + method +
               " --width 32 --height 32 --spp 1 --grid-surface desk --grid-spacing 0.2 --stats " +
               stats + " -o " + dir.file(method + "-desk.png"));
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return readJson(stats)["illuminance"]["surface"];
  };
  const nlohmann::json radiosity = desk("progressive"), traced = desk("pathtrace");
  const double e_r = radiosity["total"]["average_lux"], e_p = traced["total"]["average_lux"];
  std::printf("desk: radiosity %.1f lx, path tracer %.1f lx, minimum %.1f lx\n", e_r, e_p,
              double(radiosity["total"]["minimum_lux"]));
  EXPECT_NEAR(e_r / e_p, 1.0, 0.03);
  EXPECT_GT(int(radiosity["points"]), 100);
  EXPECT_LT(double(radiosity["total"]["minimum_lux"]), 0.05 * e_r);  // the face on the floor
  const test::CliResult bad = runCli(
      "render " + scene + " --method progressive --grid-surface chair -o " + dir.file("x.png"));
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("no mesh is named 'chair'"), std::string::npos) << bad.output;
  // Refused before the work: no lightmap was built.
  EXPECT_EQ(bad.output.find("lightmap texels"), std::string::npos) << bad.output;
  const test::CliResult dense =
      runCli("render " + scene + " --method matrix --work-plane 0.75 --grid-spacing 1e-9 -o " +
             dir.file("y.png"));
  EXPECT_EQ(dense.exit_code, 2) << dense.output;
  EXPECT_NE(dense.output.find("at most 4 million"), std::string::npos) << dense.output;
  EXPECT_EQ(dense.output.find("form factors"), std::string::npos) << dense.output;
}

TEST(LightingDesign, FalseColourImageHasALegendAndLuxInExr) {
  TempDir dir;
  const std::string png = dir.file("lux.png"), exr = dir.file("lux.exr");
  const test::CliResult r = runCli(
      "render cornell --method progressive --width 64 --height 64 --output-quantity "
      "illuminance --false-colour --lux-max 400 --illuminance-rays 64 -o " +
      png + " -o " + exr);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  Expected<Image> picture = readImage(png), lux = readImage(exr);
  ASSERT_TRUE(picture.ok() && lux.ok());
  EXPECT_GT(picture->width, 64);  // the legend to the right
  EXPECT_EQ(lux->width, 64);
  // The EXR holds lux: the same value in every channel, finite, some lit.
  double peak = 0.0;
  for (const glm::vec3& p : lux->pixels) {
    EXPECT_EQ(p.x, p.y);
    EXPECT_TRUE(std::isfinite(p.x));
    peak = std::max(peak, double(p.x));
  }
  EXPECT_GT(peak, 1.0);
  const test::CliResult bad = runCli("render cornell --false-colour -o " + dir.file("x.png"));
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  const test::CliResult sss = runCli("render sss --method sss --work-plane 0.5");
  EXPECT_EQ(sss.exit_code, 2) << sss.output;
}

}  // namespace
}  // namespace penumbra
