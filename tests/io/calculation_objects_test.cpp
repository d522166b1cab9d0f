// Calculation objects as users write them (io/calculation_objects.h): grids on any plane,
// work planes, surfaces and points from JSON and CSV, each value checked with the file and the
// place named, and the 4 million point limit before anything is made.
#include "penumbra/io/calculation_objects.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

namespace penumbra {
namespace {

using nlohmann::json;
using test::TempDir;

Scene box() {
  Scene s;
  s.source = "test:box";
  s.materials = {{"white", glm::vec3(0.5f), glm::vec3(0.0f)}};
  s.meshes.push_back(test::boxMesh(4.0, 3.0, 5.0));
  s.meshes.back().name = "room";
  return s;
}

TEST(CalculationObjects, AVerticalGridOnAWallHasItsCellsAndNormal) {
  const Scene s = box();
  const json list = json::parse(R"([
    {"name": "east wall", "type": "grid", "origin": [4, 0, 0], "u": [0, 0, 5], "v": [0, 3, 0],
     "normal": [-1, 0, 0], "spacing": 0.5, "margin": 0.25}
  ])");
  Expected<std::vector<CalculationGrid>> g = calculationObjectsFromJson(s, list, "s.json", "calc");
  ASSERT_TRUE(g.ok()) << g.error().describe();
  ASSERT_EQ(g->size(), 1u);
  const CalculationGrid& wall = (*g)[0];
  EXPECT_EQ(wall.name, "east wall");
  EXPECT_EQ(wall.columns, 9);  // 4.5 m / 0.5
  EXPECT_EQ(wall.rows, 5);     // 2.5 m / 0.5
  EXPECT_EQ(wall.points.front(), glm::dvec3(4.0, 0.5, 0.5));
  for (const glm::dvec3& n : wall.normals) EXPECT_EQ(n, glm::dvec3(-1, 0, 0));
  EXPECT_EQ(wall.measure, Measure::kPlanar);
}

TEST(CalculationObjects, InclinedGridsAndCylindricalPoints) {
  const Scene s = box();
  const double c = std::sqrt(0.5);
  const json list = json::parse(R"([
    {"type": "grid", "origin": [0, 1, 0], "u": [2, 0, 0], "v": [0, 1, 1], "spacing": 0.25},
    {"name": "seats", "type": "points", "measure": "cylindrical",
     "points": [{"position": [1, 1.2, 2], "name": "A"}, {"position": [3, 1.2, 2]}]},
    {"name": "desks", "type": "work_plane", "height": 0.75, "spacing": 1}
  ])");
  Expected<std::vector<CalculationGrid>> g = calculationObjectsFromJson(s, list, "s.json", "calc");
  ASSERT_TRUE(g.ok()) << g.error().describe();
  ASSERT_EQ(g->size(), 3u);
  // The normal of an inclined grid defaults to u x v.
  EXPECT_NEAR(glm::length((*g)[0].normals[0] - glm::dvec3(0, -c, c)), 0.0, 1e-12);
  EXPECT_EQ((*g)[0].name, "grid 1");
  EXPECT_EQ((*g)[1].measure, Measure::kCylindrical);
  EXPECT_EQ((*g)[1].normals[1], glm::dvec3(0, 1, 0));  // the vertical axis
  EXPECT_EQ((*g)[1].labels, (std::vector<std::string>{"A", ""}));
  EXPECT_EQ((*g)[2].points.size(), 4u * 5u);
}

TEST(CalculationObjects, BadValuesNameTheFileAndThePlace) {
  const Scene s = box();
  const auto bad = [&](const char* text) {
    return calculationObjectsFromJson(s, json::parse(text), "s.json", "calculation");
  };
  EXPECT_TRUE(test::errorNames(bad(R"([{"type": "plane"}])"), "s.json", "calculation[0].type"));
  EXPECT_TRUE(test::errorNames(
      bad(R"([{"type": "grid", "origin": [0, 0, 0], "u": [1, 0, 0], "v": [1, 1, 0]}])"), "s.json",
      "calculation[0]"));  // u and v not square
  EXPECT_TRUE(test::errorNames(
      bad(R"([{"type": "grid", "origin": [0, 0, 1e300], "u": [1, 0, 0], "v": [0, 1, 0]}])"),
      "s.json", "calculation[0].origin[2]"));
  EXPECT_TRUE(test::errorNames(bad(R"([{"type": "work_plane", "height": 1, "spacing": -1}])"),
                               "s.json", "calculation[0].spacing"));
  EXPECT_TRUE(test::errorNames(bad(R"([{"type": "surface", "mesh": "desk"}])"), "s.json",
                               "calculation[0].mesh"));
  EXPECT_TRUE(test::errorNames(
      bad(R"([{"type": "points", "points": [{"position": [0, 0, 0], "normal": [0, 0, 0]}]}])"),
      "s.json", "calculation[0].points[0].normal"));
  EXPECT_TRUE(test::errorNames(bad(R"([{"type": "work_plane", "height": 1, "colour": 2}])"),
                               "s.json", "calculation[0].colour"));
  // 1 mm over a 1 km square: a million points a side, refused before any is made.
  EXPECT_TRUE(test::errorNames(
      bad(R"([{"type": "grid", "origin": [0, 0, 0], "u": [1000, 0, 0], "v": [0, 0, 1000],
               "spacing": 0.001}])"),
      "s.json", "calculation[0].spacing"));
}

TEST(CalculationObjects, PointsFromCsvWithAndWithoutNormals) {
  TempDir dir;
  const std::string csv = dir.write("points.csv",
                                    "# measured points\n"
                                    "x,y,z,nx,ny,nz,name\n"
                                    "1,0.75,2,0,1,0,desk\r\n"
                                    "2,1.2,0.5,0,0,2,wall\n");
  Expected<CalculationGrid> g = readCalculationPoints(csv);
  ASSERT_TRUE(g.ok()) << g.error().describe();
  ASSERT_EQ(g->points.size(), 2u);
  EXPECT_EQ(g->name, "points");
  EXPECT_EQ(g->normals[1], glm::dvec3(0, 0, 1));  // normalised
  EXPECT_EQ(g->labels, (std::vector<std::string>{"desk", "wall"}));
  const std::string three = dir.write("three.csv", "1,2,3\n4,5,6\n");
  Expected<CalculationGrid> up = readCalculationPoints(three);
  ASSERT_TRUE(up.ok()) << up.error().describe();
  EXPECT_EQ(up->normals[0], glm::dvec3(0, 1, 0));
  const std::string broken = dir.write("broken.csv", "1,2,3\n4,5,nan\n");
  EXPECT_TRUE(test::errorNames(readCalculationPoints(broken), broken, "line 2"));
  const std::string short_row = dir.write("short.csv", "1,2,3\n4,5\n");
  EXPECT_TRUE(test::errorNames(readCalculationPoints(short_row), short_row, "line 2"));
  EXPECT_TRUE(test::errorNames(readCalculationPoints(dir.file("missing.csv")),
                               dir.file("missing.csv"), ""));
  const std::string json_points =
      dir.write("p.json", R"({"points": [{"position": [1, 2, 3], "normal": [1, 0, 0]}]})");
  Expected<CalculationGrid> j = readCalculationPoints(json_points);
  ASSERT_TRUE(j.ok()) << j.error().describe();
  EXPECT_EQ(j->normals[0], glm::dvec3(1, 0, 0));
}

}  // namespace
}  // namespace penumbra
