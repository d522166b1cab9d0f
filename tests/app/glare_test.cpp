// UGR at an observer in a scene (render/glare.h), as a lighting designer gets it from a render,
// against the tabular method of CIE 190:2010 (render/ugr_table.h) for the room the table stands
// for: 4H x 8H or 8H x 4H with H = 2 m, luminaires at S = 0.25 H in the ceiling 2 m above the
// eye, the eye 1.2 m above the floor at the middle of a wall, looking along the room;
// reflectances ceiling 0.7, walls 0.5, floor 0.2. The scene's UGR takes its background from the
// radiosity solution at the eye; the table's from CIE 190's flux-transfer factors: they must
// agree within one unit, for real luminaire files, crosswise and endwise. In CIE 190's own room
// (the floor at the eye's height) the table's indirect wall illuminance E_WID is checked against
// the solution's mean over the walls.
#include "penumbra/io/photometry.h"
#include "penumbra/render/ugr_table.h"
#include "support/test_util.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>

namespace penumbra {
namespace {

using test::runCli;
using test::TempDir;

std::string photometryFile(const std::string& name) {
  return std::string(PENUMBRA_SOURCE_DIR) + "/tests/data/photometry/" + name;
}

std::string quad(double ax, double ay, double az, double bx, double by, double bz, double cx,
                 double cy, double cz, double dx, double dy, double dz) {
  return fmt::format("v {} {} {}\nv {} {} {}\nv {} {} {}\nv {} {} {}\nf -4 -3 -2\nf -4 -2 -1\n", ax,
                     ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz);
}

// The standard room, x_h H across the line of sight (world x) and y_h H along it (world z), the
// eye at the origin looking along +z, the ceiling and luminaires 2 m above it, the floor `below`
// m under it; luminaires `rotation` degrees from C0 along x (90: C0 along the line of sight,
// crosswise). Returns the stats of a progressive render: the glare object, then the walls'.
nlohmann::json renderStandardRoom(const TempDir& dir, const std::string& ldt, int x_h, int y_h,
                                  double rotation, double below) {
  const double h = kUgrMountingHeight, x = x_h * h / 2.0, y = y_h * h, s = 0.25 * h;
  dir.write("floor.obj", quad(-x, -below, 0, -x, -below, y, x, -below, y, x, -below, 0));
  dir.write("ceiling.obj", quad(-x, h, 0, x, h, 0, x, h, y, -x, h, y));
  dir.write("walls.obj", quad(-x, -below, 0, x, -below, 0, x, h, 0, -x, h, 0) +
                             quad(x, -below, y, -x, -below, y, -x, h, y, x, h, y) +
                             quad(-x, -below, y, -x, -below, 0, -x, h, 0, -x, h, y) +
                             quad(x, -below, 0, x, -below, y, x, h, y, x, h, 0));
  const nlohmann::json scene = {
      {"materials",
       {{"floor", {{"reflectance", {0.2, 0.2, 0.2}}}},
        {"walls", {{"reflectance", {0.5, 0.5, 0.5}}}},
        {"ceiling", {{"reflectance", {0.7, 0.7, 0.7}}}}}},
      {"meshes",
       {{{"file", "floor.obj"}, {"material", "floor"}, {"name", "floor"}},
        {{"file", "walls.obj"}, {"material", "walls"}, {"name", "walls"}},
        {{"file", "ceiling.obj"}, {"material", "ceiling"}, {"name", "ceiling"}}}},
      {"lights",
       {{{"type", "luminaire"},
         {"file", photometryFile(ldt)},
         {"position", {0.0, h - 1e-3, y / 2.0}},
         {"rotation_deg", rotation},
         {"array",
          {{"count", {int(std::lround(2 * x / s)), int(std::lround(y / s))}},
           {"spacing", {s, s}}}}}}},
      {"calculation",
       {{{"name", "glare"},
         {"type", "glare"},
         {"observers",
          {{{"position", {0.0, below > 0.0 ? 0.0 : 0.01, 0.01}}, {"view", {0, 0, 1}}}}}},
        {{"name", "walls"}, {"type", "surface"}, {"mesh", "walls"}, {"spacing", 0.5}}}},
      {"camera", {{"position", {0, 1, -1}}, {"look_at", {0, 1, 8}}, {"fov_deg", 60}}}};
  const std::string path = dir.write("room.json", scene.dump());
  const test::CliResult r =
      runCli("render " + path + " --method progressive --width 16 --height 16 -o " +
             dir.file("room.png") + " --stats " + dir.file("stats.json"));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  return test::readJson(dir.file("stats.json"))["illuminance"]["objects"];
}

struct StandardCase {
  std::string file;
  int x_h, y_h;
  bool endwise;
};

TEST(Glare, StandardRoomAgreesWithCie190sTableWithinOneUnit) {
  const StandardCase cases[] = {{"ledvance_biolux_dn150.ldt", 4, 8, false},
                                {"sample_isym1.ldt", 8, 4, false},
                                {"sample_isym3.ldt", 4, 8, false},
                                {"sample_isym3.ldt", 4, 8, true}};
  for (const StandardCase& c : cases) {
    Expected<Photometry> p = readPhotometry(photometryFile(c.file));
    ASSERT_TRUE(p) << p.error().message;
    Expected<std::vector<UgrTableRow>> table = ugrTable(*p);
    ASSERT_TRUE(table);
    double tabular = std::nan("");
    for (const UgrTableRow& row : *table) {
      if (row.room.x_h == c.x_h && row.room.y_h == c.y_h && row.reflectances.walls == 0.5 &&
          row.reflectances.ceiling == 0.7) {
        tabular = c.endwise ? row.endwise : row.crosswise;
      }
    }
    TempDir dir;
    const nlohmann::json objects =
        renderStandardRoom(dir, c.file, c.x_h, c.y_h, c.endwise ? 0.0 : 90.0, 1.2);
    const nlohmann::json& observer = objects[0]["observers"][0];
    ASSERT_TRUE(observer["ugr"].is_number()) << observer.dump();
    const double ugr = observer["ugr"].get<double>();
    EXPECT_NEAR(ugr, tabular, 1.0) << c.file << " " << c.x_h << "H x " << c.y_h << "H "
                                   << (c.endwise ? "endwise" : "crosswise");
    EXPECT_GT(tabular, 10.0);  // a real rating, not a vanishing sum
    EXPECT_EQ(objects[0]["ugr_max"].get<double>(), ugr);
  }
}

// In CIE 190's own room (the floor cavity as a plane of reflectance 0.2 at the eye's height, the
// walls between it and the luminaires), the table's indirect wall illuminance is the solution's
// mean over the walls: the transfer factors of Table 5 hold for the radiosity of the room.
TEST(Glare, Cie190sWallIlluminanceIsTheRadiositySolutions) {
  for (const std::string file : {"ledvance_biolux_dn150.ldt", "sample_isym1.ldt"}) {
    Expected<Photometry> p = readPhotometry(photometryFile(file));
    ASSERT_TRUE(p);
    TempDir dir;
    const nlohmann::json objects = renderStandardRoom(dir, file, 4, 8, 0.0, 0.0);
    const nlohmann::json& walls = objects[1];
    const double indirect =
        walls["total"]["average_lux"].get<double>() - walls["direct"]["average_lux"].get<double>();
    const double tabular = ugrWallIndirectIlluminance(ugrZonalFlux(*p), {4, 8, 0.25}, 0);
    EXPECT_NEAR(indirect, tabular, 0.06 * tabular) << file;
  }
}

// `info` prints the file's table as the library computes it.
TEST(Glare, InfoPrintsTheFilesUgrTable) {
  const std::string file = photometryFile("sample_isym3.ldt");
  Expected<Photometry> p = readPhotometry(file);
  ASSERT_TRUE(p);
  Expected<std::vector<UgrTableRow>> table = ugrTable(*p);
  ASSERT_TRUE(table);
  const test::CliResult r = runCli("info " + file);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const UgrTableRow& first = (*table)[0];  // 4H x 8H, 70/50/20
  EXPECT_NE(r.output.find(fmt::format("4H x 8H {:.1f} / {:.1f}", first.crosswise, first.endwise)),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("70/50/20"), std::string::npos) << r.output;
}

// Glare objects are input like the rest: one error line naming the place, exit code 2.
TEST(Glare, BadObserversAreRefusedNamingThePlace) {
  TempDir dir;
  const std::string mesh = dir.write("floor.obj", quad(-5, 0, -5, -5, 0, 5, 5, 0, 5, 5, 0, -5));
  const struct {
    std::string observers, needle;
  } cases[] = {
      {R"([{"position": [0, 1, 0]}])", "calculation[0].observers[0].view: missing"},
      {R"([{"position": [0, 1, 0], "view": [0, 1, 0.01]}])",
       "calculation[0].observers[0].view: a line of sight within 5 degrees of the vertical"},
      {R"([{"position": [0, 1, 0], "view": [0, 0, 1], "normal": [0, 1, 0]}])",
       "calculation[0].observers[0].normal: unknown key"},
      {R"([{"position": [0, 1e30, 0], "view": [0, 0, 1]}])",
       "calculation[0].observers[0].position"},
      {"[]", "calculation[0].observers: no observers"},
  };
  for (const auto& c : cases) {
    const std::string scene = dir.write(
        "s.json",
        R"({"meshes": [{"file": ")" + mesh +
            R"("}], "lights": [{"type": "point", "position": [0, 2, 0], "intensity": [1, 1, 1]}],
                       "calculation": [{"type": "glare", "observers": )" +
            c.observers + "}]}");
    const test::CliResult r =
        runCli("render " + scene + " --method progressive -o " + dir.file("x.png"));
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find(c.needle), std::string::npos) << c.needle << "\n" << r.output;
    EXPECT_FALSE(std::filesystem::exists(dir.file("x.png")));
  }
}

}  // namespace
}  // namespace penumbra
