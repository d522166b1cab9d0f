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

std::string fileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(LightingDesign, CalculationObjectsAreReportedAndTakeNoPartInTheLight) {
  TempDir dir;
  const std::string scene = std::string(PENUMBRA_SOURCE_DIR) + "/scenes/office.json";
  const std::string points = dir.write("seats.csv",
                                       "x,y,z,nx,ny,nz,name\n"
                                       "1.0,1.2,2.0,0,1,0,seat A\n"
                                       "3.0,1.2,2.0,0,0,-1,seat B\n");
  const std::string calc = dir.write("objects.json", R"({"calculation": [
    {"name": "east wall", "type": "grid", "origin": [4, 0, 0], "u": [0, 0, 5], "v": [0, 3, 0],
     "normal": [-1, 0, 0], "spacing": 0.5},
    {"name": "seats cylindrical", "type": "points", "measure": "cylindrical",
     "points": [{"position": [2, 1.2, 2.5], "name": "middle"}]}
  ]})");
  for (const char* m : {"progressive", "pathtrace"}) {
    const std::string method = m;
    const std::string plain = dir.file(method + "-plain.exr");
    const std::string with = dir.file(method + "-with.exr");
    const std::string report = dir.file(method + "-report");
    const std::string stats = dir.file(method + "-stats.json");
    const std::string common =
        "render " + scene + " --method " + method + " --width 48 --height 32 --spp 2 --seed 3 ";
    const test::CliResult a = runCli(common + "-o " + plain);
    ASSERT_EQ(a.exit_code, 0) << a.output;
    const test::CliResult b = runCli(common + "--points " + points + " --calc " + calc +
                                     " --report " + report + " --stats " + stats + " -o " + with);
    ASSERT_EQ(b.exit_code, 0) << b.output;
    // The points measure; the picture is the same to the byte.
    EXPECT_EQ(fileBytes(plain), fileBytes(with)) << method;
    const nlohmann::json objects = readJson(stats)["illuminance"]["objects"];
    ASSERT_EQ(objects.size(), 3u);
    EXPECT_EQ(objects[0]["name"], "east wall");
    EXPECT_EQ(objects[2]["name"], "seats");  // the points file's stem
    EXPECT_EQ(objects[1]["measure"], "cylindrical");
    const nlohmann::json wall = readJson(report + "/east_wall.json");
    EXPECT_EQ(wall["point_values"].size(), 10u * 6u);
    const double avg = wall["total"]["average_lux"], lo = wall["total"]["minimum_lux"],
                 hi = wall["total"]["maximum_lux"];
    EXPECT_GT(avg, 50.0);  // six 2000 lm downlights light the walls too
    EXPECT_NEAR(double(wall["total"]["uniformity_u1"]), lo / hi, 1e-9);
    EXPECT_NEAR(double(wall["total"]["uniformity_u0"]), lo / avg, 1e-9);
    Expected<Image> plan = readImage(report + "/east_wall.png");
    ASSERT_TRUE(plan.ok()) << plan.error().describe();
    EXPECT_GT(plan->width, 10 * 40);  // a cell per point and the legend
    std::ifstream seats(report + "/seats.csv");
    std::string line, all;
    while (std::getline(seats, line)) all += line + "\n";
    EXPECT_NE(all.find("seat A,1.0000,1.2000,2.0000"), std::string::npos) << all;
    EXPECT_NE(all.find("seat B"), std::string::npos) << all;
    std::printf("office, %s: east wall E_avg %.1f lx, U0 %.2f; cylindrical at the middle %.1f lx\n",
                method.c_str(), avg, double(wall["total"]["uniformity_u0"]),
                double(objects[1]["total"]["average_lux"]));
  }
}

TEST(LightingDesign, BadCalculationObjectsAreRefusedBeforeTheWork) {
  TempDir dir;
  const std::string scene = std::string(PENUMBRA_SOURCE_DIR) + "/scenes/office.json";
  const std::string out = dir.file("x.png"), report = dir.file("report");
  const std::string bad = dir.write("bad.csv", "1,2,3\n4,5,six\n");
  const test::CliResult r = runCli("render " + scene + " --method progressive --points " + bad +
                                   " --report " + report + " -o " + out);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find(bad + ": line 2"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("lightmap texels"), std::string::npos) << "refused before the work";
  EXPECT_FALSE(std::filesystem::exists(out));
  EXPECT_FALSE(std::filesystem::exists(report));
  const std::string calc = dir.write("c.json", R"([{"type": "grid", "origin": [0, 0, 0],
    "u": [1, 0, 0], "v": [0, 1, 0], "spacing": 0}])");
  const test::CliResult c =
      runCli("render " + scene + " --method pathtrace --calc " + calc + " -o " + out);
  EXPECT_EQ(c.exit_code, 2) << c.output;
  EXPECT_NE(c.output.find(calc + ": [0].spacing"), std::string::npos) << c.output;
  // A scene file's own objects go through the same checks.
  const std::string in_scene = dir.write("scene.json", R"({
    "materials": {"white": {"reflectance": [0.5, 0.5, 0.5]}},
    "meshes": [{"file": ")" + std::string(PENUMBRA_SOURCE_DIR) +
                                                           R"(/scenes/room/floor.obj",
                "material": "white"}],
    "calculation": [{"type": "points", "points": [{"position": [0, NaN, 0]}]}]})");
  const test::CliResult s = runCli("info " + in_scene);
  EXPECT_EQ(s.exit_code, 2) << s.output;
  EXPECT_NE(s.output.find(in_scene), std::string::npos) << s.output;
}

}  // namespace
}  // namespace penumbra
