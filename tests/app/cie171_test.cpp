// CIE 171:2006, "Test cases to assess the accuracy of lighting computer programs": the analytical
// electric-light cases as lighting designers run them, from the scene files in scenes/cie171/
// (their calculation points carry the report's labels), with progressive radiosity and the path
// tracer at their default settings. Every point must be within 5% of the report's figure and
// each case's mean error within 2% (the criteria of the validations published for other
// programs). The figures are the report's tables; case 5.7 uses Table 19 as corrected in later
// validations (the printed table was computed for another geometry). docs/lighting-design.md
// lists the results beside other programs'.
#include "support/test_util.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <numbers>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace penumbra {
namespace {

using test::runCli;
using test::TempDir;

std::string ciePath(const std::string& file) {
  return std::string(PENUMBRA_SOURCE_DIR) + "/scenes/cie171/" + file;
}

// The points of the object's report: name -> total lux.
std::map<std::string, double> renderPoints(const TempDir& dir, const std::string& scene,
                                           const std::string& method, const std::string& object,
                                           const std::string& extra = "") {
  const std::string report = dir.file(method + "-report");
  const test::CliResult r =
      runCli("render " + scene + " --method " + method + " --width 16 --height 16 --report " +
             report + " -o " + dir.file(method + ".png") + " " + extra);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  std::map<std::string, double> out;
  const nlohmann::json j = test::readJson(report + "/" + object + ".json");
  for (const nlohmann::json& p : j["point_values"]) {
    out[p.value("name", std::string())] = p["total_lux"].get<double>();
  }
  return out;
}

struct Reference {
  std::string point;
  double lux;
};

// Checks every point against the reference: within 5% (or 0.05 lx of a zero), mean error 2%.
void expectWithinCieLimits(const std::map<std::string, double>& got,
                           const std::vector<Reference>& reference, const std::string& what) {
  double sum = 0.0;
  int n = 0;
  std::string line;
  for (const Reference& ref : reference) {
    ASSERT_TRUE(got.count(ref.point)) << what << ": no point " << ref.point;
    const double e = got.at(ref.point);
    if (ref.lux == 0.0) {
      EXPECT_LT(std::fabs(e), 0.05) << what << " point " << ref.point;
      continue;
    }
    const double err = e / ref.lux - 1.0;
    EXPECT_LT(std::fabs(err), 0.05)
        << what << " point " << ref.point << ": " << e << " lx, CIE " << ref.lux;
    sum += std::fabs(err);
    ++n;
    char buf[64];
    std::snprintf(buf, sizeof buf, " %s %+.2f%%", ref.point.c_str(), 100.0 * err);
    line += buf;
  }
  const double mean = n > 0 ? sum / n : 0.0;
  std::printf("%s: mean |error| %.2f%%;%s\n", what.c_str(), 100.0 * mean, line.c_str());
  EXPECT_LT(mean, 0.02) << what;
}

const char* const kMethods[] = {"progressive", "pathtrace"};

// The report's figures (scenes/cie171/reference.json).
const nlohmann::json& references() {
  static const nlohmann::json j = test::readJson(ciePath("reference.json"));
  return j;
}

const nlohmann::json& referenceCase(const std::string& name) {
  for (const nlohmann::json& c : references()["cases"]) {
    if (c["case"] == name) return c;
  }
  throw std::runtime_error("no case " + name + " in reference.json");
}

std::vector<Reference> referencePoints(const nlohmann::json& c) {
  std::vector<Reference> out;
  for (auto it = c["points"].begin(); it != c["points"].end(); ++it) {
    out.push_back({it.key(), it.value().get<double>()});
  }
  return out;
}

// Every case with calculation points, both methods at their defaults.
void runPointCase(const std::string& name) {
  const nlohmann::json& c = referenceCase(name);
  TempDir dir;
  for (const char* m : kMethods) {
    expectWithinCieLimits(renderPoints(dir, ciePath(c["scene"]), m, c["object"]),
                          referencePoints(c), name + " " + m);
  }
}

TEST(Cie171, PointSourceCase52) {
  runPointCase("5.2");
}

TEST(Cie171, AreaSourceCase53BothWaysOfModellingThePanel) {
  const std::vector<Reference> table = referencePoints(referenceCase("5.3"));
  TempDir dir;
  for (const char* m : kMethods) {
    const auto hole = renderPoints(dir, ciePath("case_5_3.json"), m, "wall_and_floor");
    expectWithinCieLimits(hole, table, std::string("5.3 panel in a hole, ") + m);
    // The panel drawn on the unbroken ceiling: the emitter wins, the lux are the same.
    const auto on = renderPoints(dir, ciePath("case_5_3_on_ceiling.json"), m, "wall_and_floor");
    expectWithinCieLimits(on, table, std::string("5.3 panel on the ceiling, ") + m);
    for (const auto& [point, lux] : hole) EXPECT_NEAR(on.at(point), lux, 1e-3 * lux) << m << point;
  }
  // `info` says what it did.
  const test::CliResult info = runCli("info " + ciePath("case_5_3_on_ceiling.json"));
  EXPECT_EQ(info.exit_code, 0) << info.output;
  EXPECT_NE(info.output.find("of emitter 'panel' lie on 'ceiling': the emitter wins"),
            std::string::npos)
      << info.output;
}

TEST(Cie171, AreaSourceIsStableAcrossSeeds) {
  // The closed form leaves nothing to chance where nothing occludes: seeds agree to rounding;
  // where the obstruction of case 5.7 hides part of the source, and for the light case 5.6's
  // points gather from the lit surface, to 0.5%.
  TempDir dir;
  for (const char* scene : {"case_5_3.json", "case_5_7.json", "case_5_6.json"}) {
    const char* object = std::string(scene) == "case_5_6.json" ? "planes" : "wall_and_floor";
    const auto a = renderPoints(dir, ciePath(scene), "progressive", object, "--seed 1");
    const auto b = renderPoints(dir, ciePath(scene), "progressive", object, "--seed 2");
    const double tolerance = std::string(scene) == "case_5_3.json" ? 1e-9 : 5e-3;
    for (const auto& [point, lux] : a) {
      EXPECT_NEAR(b.at(point), lux, tolerance * std::max(lux, 1.0)) << scene << " " << point;
    }
  }
}

TEST(Cie171, FluxConservationCase54) {
  // 10,000 lm in a closed black 4 m x 4 m x 3 m room: 125 lx over its 80 m^2.
  const double reference = referenceCase("5.4")["average"];
  TempDir dir;
  for (const char* m : kMethods) {
    const std::string stats = dir.file(std::string(m) + ".json");
    const test::CliResult r =
        runCli("render " + ciePath("case_5_4.json") + " --method " + m +
               " --width 16 --height 16 --stats " + stats + " -o " + dir.file("x.png"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const nlohmann::json o = test::readJson(stats)["illuminance"]["objects"][0];
    const double e = o["total"]["average_lux"];
    std::printf("5.4 %s: E_avg %.3f lx over the room (%.0f lx), %+.3f%%\n", m, e, reference,
                100.0 * (e / reference - 1.0));
    EXPECT_NEAR(e, reference, 0.005 * reference) << m;
  }
}

TEST(Cie171, ReflectionFromADiffuseSurfaceCase56) {
  // The points face away from the beam: all their light is what S2 reflects.
  runPointCase("5.6");
}

TEST(Cie171, InternalObstructionCase57) {
  runPointCase("5.7");
}

// A copy of scenes/cie171/`scene` in `dir` with `from` replaced by `to` and its mesh files
// named by absolute path.
std::string sceneVariant(const TempDir& dir, const std::string& scene,
                         const std::vector<std::pair<std::string, std::string>>& edits,
                         const std::string& name) {
  std::ifstream in(ciePath(scene));
  std::stringstream text;
  text << in.rdbuf();
  std::string s = text.str();
  for (const auto& [from, to] : edits) {
    const size_t at = s.find(from);
    if (at == std::string::npos) throw std::runtime_error(scene + " has no " + from);
    s.replace(at, from.size(), to);
  }
  const std::string file = "\"file\": \"";
  for (size_t k = s.find(file); k != std::string::npos; k = s.find(file, k + 1)) {
    s.insert(k + file.size(), ciePath(""));
  }
  return dir.write(name, s);
}

std::string sceneVariant(const TempDir& dir, const std::string& scene, const std::string& from,
                         const std::string& to, const std::string& name) {
  return sceneVariant(dir, scene, {{from, to}}, name);
}

// Cases 5.9-5.14: every sky type of the case (or those of `only`), both methods.
void runSkyCase(const std::string& name, const std::set<std::string>& only = {}) {
  const nlohmann::json& c = referenceCase(name);
  TempDir dir;
  for (auto it = c["sky_types"].begin(); it != c["sky_types"].end(); ++it) {
    const std::string type = it.key();
    if (!only.empty() && !only.count(type)) continue;
    const std::string scene =
        sceneVariant(dir, c["scene"], "\"type\": 12", "\"type\": " + type, "sky" + type + ".json");
    // Points whose published figure is in doubt (reference.json says why) are printed, not
    // asserted.
    std::set<std::string> unverified;
    if (c.contains("unverified") && c["unverified"].contains(type)) {
      for (const nlohmann::json& p : c["unverified"][type]) unverified.insert(p.get<std::string>());
    }
    std::vector<Reference> table;
    for (auto p = it.value().begin(); p != it.value().end(); ++p) {
      if (!unverified.count(p.key())) table.push_back({p.key(), p.value().get<double>()});
    }
    for (const char* m : kMethods) {
      expectWithinCieLimits(renderPoints(dir, scene, m, c["object"]), table,
                            name + ", sky " + type + ", " + m);
    }
  }
}

// Case 5.5: a parallel beam through clear glass at incidence 0-85 degrees, both methods. With
// the report's fall-off ("clear_glass") the lux are 1000 cos(theta) tau(theta) to rounding; the
// physical Fresnel slab of the same normal transmittance stays within 1.5% of it up to 70
// degrees, 3.1% at 80 and 5.5% at 85.
TEST(Cie171, DirectionalTransmittanceOfClearGlassCase55) {
  TempDir dir;
  auto formula = [](double c) {
    return -0.028378 +
           c * (3.156075 + c * (-3.058376 + c * (-1.428919 + c * (4.014235 - 1.775827 * c))));
  };
  for (const char* falloff : {"clear_glass", "fresnel"}) {
    for (int degrees = 0; degrees <= 85; degrees += (degrees < 80 ? 10 : 5)) {
      const double theta = degrees * std::numbers::pi / 180.0;
      const std::string beam =
          fmt::format("\"direction\": [{:.9f}, {:.9f}, 0]", std::sin(theta), -std::cos(theta));
      const std::string scene = sceneVariant(
          dir, "case_5_5.json",
          {{"\"direction\": [0, -1, 0]", beam},
           {"\"falloff\": \"clear_glass\"", fmt::format("\"falloff\": \"{}\"", falloff)}},
          "tilted.json");
      const double expected = 1000.0 * std::cos(theta) * formula(std::cos(theta));
      for (const char* m : kMethods) {
        const double got = renderPoints(dir, scene, m, "under_the_glass").at("P");
        const double tolerance = std::string(falloff) == "clear_glass" ? 0.002
                                 : degrees <= 70                       ? 0.02
                                 : degrees <= 80                       ? 0.035
                                                                       : 0.06;
        EXPECT_NEAR(got, expected, tolerance * expected)
            << falloff << ", " << degrees << " degrees, " << m;
      }
    }
  }
}

TEST(Cie171, SkyComponentUnderARoofOpeningCase59) {
  runSkyCase("5.9, 1 m x 1 m");
  runSkyCase("5.9, 4 m x 4 m");
}

TEST(Cie171, SkyAndExternallyReflectedComponentsThroughAWindowCase511) {
  runSkyCase("5.11, 2 m x 1 m");
  runSkyCase("5.11, 4 m x 3 m");
}

// Cases 5.13 and 5.14: the window with an overhang or a wall in front, lit by the sky and the
// ground; the masks' own luminance comes from each method's solution. Four skies of the sixteen
// here (overcast steep, uniform, clear, traditional overcast); bench/cie171.py runs all.
TEST(Cie171, MasksOutsideTheWindowCases513And514) {
  const std::set<std::string> skies = {"1", "5", "12", "16"};
  for (const char* c : {"5.13, 0.5 m overhang", "5.13, 1 m overhang", "5.13, 2 m overhang",
                        "5.14, 3 m wall", "5.14, 6 m wall", "5.14, 9 m wall"}) {
    runSkyCase(c, skies);
  }
}

TEST(Cie171, DaylightFactorsSplitIntoSkyAndExternallyReflectedComponents) {
  // Case 5.11, the uniform sky: in a black room the daylight factor is SC + ERC. Wall point A
  // sees only the ground through the window (SC 0, ERC 0.95%), the ceiling only the ground,
  // the floor only the sky.
  TempDir dir;
  const std::string scene =
      sceneVariant(dir, "case_5_11_2x1.json", "\"type\": 12", "\"type\": 5", "uniform.json");
  const std::string report = dir.file("report");
  const test::CliResult r = runCli("render " + scene +
                                   " --method progressive --width 16 "
                                   "--height 16 --report " +
                                   report + " -o " + dir.file("x.png"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json j = test::readJson(report + "/wall_floor_ceiling.json");
  EXPECT_EQ(double(j["daylight"]["horizontal_illuminance_lux"]), 10000.0);
  for (const nlohmann::json& p : j["point_values"]) {
    const std::string name = p["name"];
    const double sc = p["sky_component_pct"], erc = p["externally_reflected_component_pct"],
                 df = p["daylight_factor_pct"];
    EXPECT_NEAR(df, sc + erc, 1e-9 * std::max(df, 1.0)) << name;
    if (name == "A") {
      EXPECT_EQ(sc, 0.0);
      EXPECT_NEAR(erc, 0.95, 0.02);
    }
    if (name.back() == '\'') EXPECT_EQ(sc, 0.0) << name;  // the ceiling sees no sky
    if (name == "J") EXPECT_EQ(erc, 0.0) << name;         // the floor sees no ground
  }
}

TEST(Cie171, SkyComponentUnderAGlazedRoofOpeningCase510) {
  runSkyCase("5.10, 1 m x 1 m");
  runSkyCase("5.10, 4 m x 4 m");
}

TEST(Cie171, ThroughAGlazedWindowCase512) {
  runSkyCase("5.12, 2 m x 1 m");
  runSkyCase("5.12, 4 m x 3 m");
}

TEST(Cie171, InterreflectionInACubeCase58) {
  // Table 20 / eq. 16: the interreflected illuminance averaged over the cube,
  // rho Phi / (S (1 - rho)), Phi = 10,000 lm, S = 96 m^2.
  TempDir dir;
  std::ifstream in(ciePath("case_5_8.json"));
  std::stringstream text;
  text << in.rdbuf();
  for (const double rho : {0.5, 0.9}) {
    std::string scene = text.str();
    const std::string from = "[0.8, 0.8, 0.8]";
    scene.replace(scene.find(from), from.size(), fmt::format("[{0}, {0}, {0}]", rho));
    const std::string cube = "\"cube.obj\"";
    scene.replace(scene.find(cube), cube.size(), "\"" + ciePath("cube.obj") + "\"");
    const std::string path = dir.write(fmt::format("cube-{}.json", rho), scene);
    const double reference = rho * 10000.0 / (96.0 * (1.0 - rho));
    for (const char* m : kMethods) {
      const std::string stats = dir.file(fmt::format("{}-{}.json", m, rho));
      const test::CliResult r =
          runCli("render " + path + " --method " + m + " --width 16 --height 16 --stats " + stats +
                 " -o " + dir.file("x.png"));
      ASSERT_EQ(r.exit_code, 0) << r.output;
      const nlohmann::json o = test::readJson(stats)["illuminance"]["objects"][0];
      const double indirect =
          double(o["total"]["average_lux"]) - double(o["direct"]["average_lux"]);
      std::printf("5.8 %s rho %.2f: interreflected %.1f lx, CIE %.1f, %+.2f%%\n", m, rho, indirect,
                  reference, 100.0 * (indirect / reference - 1.0));
      EXPECT_NEAR(indirect / reference, 1.0, 0.02) << m << " rho " << rho;
    }
  }
}

// A sunlit room, white inside (reflectance 0.6), behind a glazed 2 m x 1 m window in a black
// facade 204 m wide, sky type 12 with a 60,000 lx sun at 40 degrees: the ceiling sees no sun and
// little sky, so its light is interreflection, most of it from the sun patch on the floor.
// Progressive radiosity must agree with the path tracer there. Before its books counted what the
// sun delivers to the surfaces that take part (not pi r^2 E over the bounding sphere, nor the sun
// absorbed by the black facade), it stopped after the lights' iteration and the ceiling came out
// 20-23% dark at 100,000-400,000 elements. The elements are set: at the default budget, spent
// mostly on the facade, the room's sun patch is coarse and the ceiling moves by about 10% with
// the layout (docs/lighting-design.md).
TEST(Cie171, SunlitRoomBehindABlackFacadeAgreesWithThePathTracer) {
  TempDir dir;
  const std::string scene = dir.write(
      "sunlit.json", fmt::format(R"({{
    "materials": {{"wall": {{"reflectance": [0.6, 0.6, 0.6]}}, "black": {{"reflectance": [0, 0, 0]}}}},
    "meshes": [
      {{"file": "{0}", "material": "wall", "name": "room"}},
      {{"file": "{1}", "material": "wall", "name": "window wall"}},
      {{"file": "{2}", "material": "black", "name": "facade"}}
    ],
    "sky": {{"type": 12, "horizontal_illuminance": 10000, "ground_reflectance": 0.3,
             "sun": {{"elevation_deg": 40, "azimuth_deg": 180}}, "sun_illuminance": 60000,
             "north": [0, 0, 1]}},
    "openings": [{{"name": "window", "glazing": {{"transmittance": 0.8788, "falloff": "clear_glass"}},
                   "corners": [[1, 1, 0], [3, 1, 0], [3, 2, 0], [1, 2, 0]]}}],
    "calculation": [{{"name": "ceiling", "type": "points", "points": [
      {{"name": "G'", "position": [2, 3, 3.75], "normal": [0, -1, 0]}},
      {{"name": "J'", "position": [2, 3, 2.25], "normal": [0, -1, 0]}},
      {{"name": "M'", "position": [2, 3, 0.75], "normal": [0, -1, 0]}},
      {{"name": "back wall", "position": [2, 1.5, 4], "normal": [0, 0, -1]}}]}}]
  }})",
                                 ciePath("facade_room.obj"), ciePath("facade_wall_2x1.obj"),
                                 ciePath("facade_2x1.obj")));
  const std::map<std::string, double> pt = renderPoints(dir, scene, "pathtrace", "ceiling");
  const std::map<std::string, double> pr =
      renderPoints(dir, scene, "progressive", "ceiling", "--elements 200000");
  ASSERT_EQ(pt.size(), 4u);
  for (const auto& [name, lux] : pt) {
    ASSERT_TRUE(pr.count(name)) << name;
    std::printf("sunlit room %s: progressive %.1f lx, path tracer %.1f lx, %+.2f%%\n", name.c_str(),
                pr.at(name), lux, 100.0 * (pr.at(name) / lux - 1.0));
    EXPECT_GT(lux, 1000.0) << name;  // interreflection, not the sky alone (400-900 lx)
    EXPECT_NEAR(pr.at(name) / lux, 1.0, 0.04) << name;
  }
}

}  // namespace
}  // namespace penumbra
