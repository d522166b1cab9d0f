// Numbers and files as a hostile user gives them: each case once crashed, hung, wrote a NaN image,
// replaced a device node or ran for minutes. Every one must end with exit code 2 (bad input) or
// 1 (a failed write), one error line naming the file or option, and no output left behind. The
// values inside scene files themselves are in io/scene_json_test.cpp (LightsAndEmissionThat
// OverflowAreRefused) and io/gltf_loader_test.cpp (ValuesOfTheWrongShape...); the fuzz targets
// scene_values and gltf_values search further (fuzz/README.md, docs/hostile-inputs.md).
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <nlohmann/json.hpp>

#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

namespace penumbra {
namespace {

namespace fs = std::filesystem;
using test::CliResult;
using test::TempDir;

// Runs `shell_prefix` then the CLI with `args` under a 60-second kill: a hang fails the test
// instead of stopping the suite.
CliResult runGuarded(const std::string& args, const std::string& shell_prefix = "") {
  return test::runShell(shell_prefix + "timeout -s KILL 60 " + std::string(PENUMBRA_CLI) + " " +
                        args + " 2>&1");
}

size_t errorLines(const std::string& output) {
  size_t count = 0;
  for (size_t at = output.find("error:"); at != std::string::npos;
       at = output.find("error:", at + 1)) {
    ++count;
  }
  return count;
}

#define EXPECT_REFUSED(r, code, needle)                                  \
  do {                                                                   \
    EXPECT_EQ((r).exit_code, code) << (r).output;                        \
    EXPECT_NE((r).output.find(needle), std::string::npos) << (r).output; \
    EXPECT_EQ(errorLines((r).output), 1u) << (r).output;                 \
  } while (false)

// Issue items 1 to 3: a light at 1e39 crashed every method, a luminaire colour of 1e300 gave
// +inf pixels, a scene file's spp 0 gave an all-NaN image and its width 0 rendered and then
// exited 1. Each is refused before the work by every method, --dry-run and the viewer.
TEST(HostileValues, NumbersInsideFilesAreCheckedAsTheCommandLineIs) {
  TempDir dir;
  const std::string ldt = std::string(PENUMBRA_TEST_DATA) + "/photometry/sample_isym1.ldt";
  const auto scene = [&](const std::string& name, const nlohmann::json& extra) {
    nlohmann::json s = {
        {"meshes", {{{"sphere", 2}}}},
        {"lights", {{{"type", "point"}, {"position", {0, 3, 0}}, {"intensity", {1, 1, 1}}}}}};
    s.update(extra);
    return dir.write(name, s.dump());
  };
  const struct {
    std::string file, needle;
  } cases[] = {
      {scene("far.json",
             {{"lights",
               {{{"type", "point"}, {"position", {1e39, 0, 0}}, {"intensity", {1, 1, 1}}}}}}),
       "light 0 (point): position (inf, 0, 0)"},
      {scene("hot.json", {{"lights",
                           {{{"type", "luminaire"},
                             {"file", ldt},
                             {"position", {0, 3, 0}},
                             {"colour", {1e300, 1, 1}}}}}}),
       "light 0 (luminaire)"},
      {scene("spp.json", {{"settings", {{"pathtrace", {{"spp", 0}}}}}}),
       "settings.pathtrace.spp: 0 is out of range"},
      {scene("width.json", {{"settings", {{"pathtrace", {{"width", 0}}}}}}),
       "settings.pathtrace.width: 0 is out of range"},
  };
  for (const auto& c : cases) {
    const bool settings =
        c.file.find("spp") != std::string::npos || c.file.find("width") != std::string::npos;
    std::vector<std::string> runs = {"render " + c.file + " --quiet -o " + dir.file("a.png"),
                                     "render " + c.file + " --dry-run -o " + dir.file("a.png")};
    if (!settings) {
      for (const char* m : {"progressive", "whitted", "stochastic", "matrix"}) {
        runs.push_back("render " + c.file + " --method " + m + " --quiet -o " + dir.file("a.png"));
      }
      runs.push_back("view " + c.file);
    }
    for (const std::string& args : runs) {
      const CliResult r = runGuarded(args, "DISPLAY= ");
      EXPECT_REFUSED(r, 2, c.needle);
    }
  }
  EXPECT_FALSE(fs::exists(dir.file("a.png")));
}

// Issue item 6: a FIFO blocked forever, /dev/zero was read until memory ran out.
TEST(HostileValues, InputsMustBeRegularFiles) {
  TempDir dir;
  ASSERT_EQ(::mkfifo(dir.file("scene.json").c_str(), 0600), 0);
  ASSERT_EQ(::mkfifo(dir.file("run.checkpoint").c_str(), 0600), 0);
  fs::create_symlink("/dev/zero", dir.file("zero.ldt"));
  fs::create_symlink("/dev/zero", dir.file("zero.pfm"));
  dir.write("tilt.ies", "IESNA:LM-63-2002\nTILT=/dev/zero\n");
  const auto scene = [&](const std::string& name, const std::string& luminaire) {
    return dir.write(
        name,
        nlohmann::json{
            {"meshes", {{{"sphere", 1}}}},
            {"lights", {{{"type", "luminaire"}, {"file", luminaire}, {"position", {0, 3, 0}}}}}}
            .dump());
  };
  const std::string out = " --quiet -o " + dir.file("out.png");
  const struct {
    std::string args, needle;
  } cases[] = {
      {"render " + dir.file("scene.json") + out, "is a FIFO, not a regular file"},
      {"info " + dir.file("scene.json"), "is a FIFO"},
      {"render cornell --method progressive --resume " + dir.file("run.checkpoint") + out,
       "is a FIFO"},
      {"trace cornell --rays /dev/zero -o " + dir.file("hits.bin"), "is a character device"},
      {"render " + scene("z.json", "zero.ldt") + out, "is a character device"},
      {"render " + scene("t.json", "tilt.ies") + out, "TILT"},
      {"render " + dir.path().string() + out, "directory"},
  };
  for (const auto& c : cases) {
    const auto started = std::chrono::steady_clock::now();
    const CliResult r = runGuarded(c.args);
    EXPECT_REFUSED(r, 2, c.needle);
    EXPECT_LT(std::chrono::steady_clock::now() - started, std::chrono::seconds(20)) << c.args;
    EXPECT_FALSE(fs::exists(dir.file("out.png")));
  }
}

// Issue item 7: outputs pointed at a device replaced it with a file, and a full disk went
// unreported. Links in a private directory stand for the devices (renaming over a link replaces
// the link, never the device, should the check fail).
TEST(HostileValues, OutputsReplaceOnlyRegularFilesAndReportFailedWrites) {
  TempDir dir;
  fs::create_symlink("/dev/null", dir.file("null.png"));
  fs::create_symlink("/dev/null", dir.file("null.json"));
  fs::create_symlink("/dev/null", dir.file("null.csv"));
  const std::string quick = "render cornell --width 8 --height 8 --spp 1 --quiet ";
  const struct {
    std::string args, needle;
  } cases[] = {
      {quick + "-o " + dir.file("null.png"), "null.png: is a character device"},
      {quick + "-o " + dir.file("a.png") + " --stats " + dir.file("null.json"), "null.json"},
      {quick + "--work-plane 0.5 --illuminance-rays 4 -o " + dir.file("a.png") + " --grid-csv " +
           dir.file("null.csv"),
       "null.csv"},
  };
  for (size_t i = 0; i < std::size(cases); ++i) {
    const CliResult r = runGuarded(cases[i].args);
    EXPECT_REFUSED(r, 2, cases[i].needle);
    EXPECT_FALSE(fs::exists(dir.file("a.png")));
  }
  struct stat st {};
  ASSERT_EQ(::stat("/dev/null", &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));
  EXPECT_TRUE(fs::is_symlink(dir.file("null.png")));

  // A file-size limit of 4 KiB stands for a full disk: every writer reports the failed write
  // (exit 1) and leaves nothing, neither the output nor a temporary.
  TempDir full;
  const std::string limit = "ulimit -f 8; trap '' XFSZ; ";
  for (const std::string& name : {"big.pfm", "big.png", "big.exr", "big.hdr"}) {
    const CliResult r = runGuarded(
        "render cornell --width 96 --height 96 --spp 1 --quiet -o " + full.file(name), limit);
    EXPECT_REFUSED(r, 1, name + ": cannot write");
  }
  const CliResult bake = runGuarded(
      "bake cornell --method matrix --elements 200 --quiet -o " + full.file("baked"), limit);
  EXPECT_EQ(bake.exit_code, 1) << bake.output;
  EXPECT_TRUE(fs::is_empty(full.path()))
      << "left behind: " << fs::directory_iterator(full.path())->path();
}

// Issue items 5 and 8: spheres and luminaire arrays from a few lines of JSON ran for minutes
// and into gigabytes; they are counted over the scene before anything is built.
TEST(HostileValues, WorkFromSmallFilesIsPlannedBeforeItIsBuilt) {
  TempDir dir;
  nlohmann::json spheres;
  for (int i = 0; i < 200; ++i) spheres["meshes"].push_back({{"sphere", 8}});
  nlohmann::json arrays;
  arrays["meshes"] = {{{"sphere", 2}}};
  for (int i = 0; i < 300; ++i) {
    arrays["lights"].push_back(
        {{"type", "luminaire"},
         {"file", std::string(PENUMBRA_TEST_DATA) + "/photometry/sample_isym1.ldt"},
         {"position", {0, 3, 0}},
         {"array", {{"count", {100, 100}}, {"spacing", {0.01, 0.01}}}}});
  }
  nlohmann::json points;
  points["meshes"] = {{{"sphere", 1}}};
  for (int i = 0; i < 10001; ++i) {
    points["lights"].push_back(
        {{"type", "point"}, {"position", {0, 2 + 1e-4 * i, 0}}, {"intensity", {1, 1, 1}}});
  }
  const struct {
    std::string file, needle;
  } cases[] = {
      {dir.write("spheres.json", spheres.dump()), "making 200 spheres of 262144000 triangles"},
      {dir.write("arrays.json", arrays.dump()), "lights[1].array: 10000 more luminaires"},
      {dir.write("points.json", points.dump()), "10001 lights; a scene may hold at most 10000"},
  };
  for (const auto& c : cases) {
    for (const std::string& method : {"pathtrace", "progressive"}) {
      const auto started = std::chrono::steady_clock::now();
      const CliResult r = runGuarded("render " + c.file + " --method " + method +
                                     " --quiet --width 8 --height 8 -o " + dir.file("a.png"));
      EXPECT_REFUSED(r, 2, c.needle);
      EXPECT_LT(std::chrono::steady_clock::now() - started, std::chrono::seconds(15));
    }
  }
  EXPECT_FALSE(fs::exists(dir.file("a.png")));
}

// Issue item 8, the other half: 10,000 luminaires from one array line (the most a scene holds)
// make progressive radiosity's first shot long (every texel sees every luminaire); SIGTERM must
// still end the run at once, not after the shot (it took 157 s).
TEST(HostileValues, SigtermEndsALongShotOfManyLuminairesAtOnce) {
  TempDir dir;
  nlohmann::json many;
  many["meshes"] = {
      {{"file", std::string(PENUMBRA_SOURCE_DIR) + "/scenes/cornell/floor.obj"},
       {"transform", {{"scale", 0.001}}}},
      {{"sphere", 3}, {"transform", {{"scale", 0.1}, {"translate", {0.25, 0.1, 0.25}}}}}};
  many["lights"] = {{{"type", "luminaire"},
                     {"file", std::string(PENUMBRA_TEST_DATA) + "/photometry/sample_isym1.ldt"},
                     {"position", {0, 2.5, 0}},
                     {"array", {{"count", {100, 100}}, {"spacing", {0.01, 0.01}}}}}};
  const std::string scene = dir.write("many.json", many.dump());
  // The shell starts the run, signals it 6 s in (inside the shot, which takes 30 s on two
  // cores) and prints the exit status and the milliseconds from the signal to the exit.
  const CliResult r =
      runGuarded("render " + scene + " --method progressive --iterations 2 --quiet -o " +
                 dir.file("a.png") + " & P=$!; sleep 6; kill -TERM $P; T=$(date +%s%N); wait $P; " +
                 "echo \"status $? after $(( ($(date +%s%N) - T) / 1000000 )) ms\"");
  int status = -1, ms = -1;
  const size_t at = r.output.find("status ");
  ASSERT_NE(at, std::string::npos) << r.output;
  ASSERT_EQ(std::sscanf(r.output.c_str() + at, "status %d after %d ms", &status, &ms), 2)
      << r.output;
  EXPECT_EQ(status, 143) << r.output;
  EXPECT_LT(ms, 3000) << r.output;
  // Nothing was solved: no image, and no temporary left.
  EXPECT_FALSE(fs::exists(dir.file("a.png")));
  for (const auto& e : fs::directory_iterator(dir.path())) {
    EXPECT_EQ(e.path().filename(), "many.json");
  }
}

// Issue items 4 and 9: --dry-run passed what the run refused, a scale of 1e30 rendered black.
TEST(HostileValues, DryRunChecksWhatTheRunChecks) {
  TempDir dir;
  const std::string huge =
      dir.write("huge.json", R"({"meshes": [{"sphere": 2, "transform": {"scale": 1e30}}],
                                 "lights": [{"type": "point", "position": [0, 3, 0],
                                             "intensity": [1, 1, 1]}]})");
  for (const std::string& run : {"", " --dry-run"}) {
    for (const std::string& method : {"progressive", "stochastic"}) {
      const CliResult coarse =
          runGuarded("render cornell --method " + method + " --texel-density 3e-4 --quiet -o " +
                     dir.file("a.png") + run);
      EXPECT_REFUSED(coarse, 2, "without a texel");
    }
    const CliResult small = runGuarded("render sss --method sss --lightmap-size 8 --quiet -o " +
                                       dir.file("a.png") + run);
    EXPECT_REFUSED(small, 2, "sss: --lightmap-size: the scene's 166 charts do not fit a 8 x 8");
    for (const std::string& method : {"pathtrace", "progressive"}) {
      const CliResult scaled = runGuarded("render " + huge + " --method " + method +
                                          " --quiet -o " + dir.file("a.png") + run);
      EXPECT_REFUSED(scaled, 2, "more than 1e+09 m from the origin");
    }
  }
  EXPECT_FALSE(fs::exists(dir.file("a.png")));
}

// A checkpoint as users make one: the run interrupted (SIGINT) a few seconds in. Longer waits
// when the machine is slow to start the run.
std::string interruptedCheckpoint(const TempDir& dir, const std::string& method) {
  const std::string ck = dir.file(method + ".checkpoint");
  std::string tries;
  for (const int seconds : {3, 6, 12, 24}) {
    const CliResult r = runGuarded("render cornell --method " + method +
                                       (method == "progressive" ? " --tolerance 1e-9" : "") +
                                       " --elements 20000 --iterations 100000 --quiet -o " +
                                       dir.file("x.png") + " --checkpoint " + ck,
                                   "timeout -s INT " + std::to_string(seconds) + " ");
    if (fs::exists(ck)) return ck;
    tries += "no checkpoint after " + std::to_string(seconds) + " s (exit " +
             std::to_string(r.exit_code) + "): " + r.output + "\n";
  }
  // Interrupted before its first iteration each time: a failure only when no wait was enough.
  ADD_FAILURE() << tries;
  return ck;
}

// Issue items 9 and 10: resuming silently took the checkpoint's --seed, --shooters,
// --shooter-points and --adaptive over the command line's, and --dry-run accepted another
// scene's checkpoint.
TEST(HostileValues, ResumeRefusesWhatTheCheckpointFixesNamingBothValues) {
  TempDir dir;
  const std::string out = " --quiet -o " + dir.file("a.png");
  const std::string progressive = interruptedCheckpoint(dir, "progressive");
  ASSERT_TRUE(fs::exists(progressive));
  const std::string resume = "render cornell --method progressive --resume " + progressive;
  const struct {
    std::string args, needle;
  } refused[] = {
      {resume + " --shooter-points 4", "was written with --shooter-points 16, not 4"},
      {resume + " --adaptive", "was written with --adaptive off, not on"},
      {resume + " --texel-density 10", "--texel-density"},
      {resume + " --elements 4000", "--elements 4000 gives"},
      {"render furnace --method progressive --resume " + progressive, "another scene"},
  };
  for (const auto& c : refused) {
    for (const std::string& run : {" --dry-run", ""}) {
      const CliResult r = runGuarded(c.args + out + run);
      EXPECT_REFUSED(r, 2, c.needle);
    }
  }
  // The values it was written with are no conflict.
  CliResult same = runGuarded(resume + " --shooter-points 16 --elements 20000 --dry-run" + out);
  EXPECT_EQ(same.exit_code, 0) << same.output;
  // A scene file's settings are held to the checkpoint as the command line is (the Cornell box
  // as a JSON scene, its mesh files named by absolute paths).
  nlohmann::json cornell =
      test::readJson(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/cornell.json");
  for (auto& mesh : cornell["meshes"]) {
    mesh["file"] = std::string(PENUMBRA_SOURCE_DIR) + "/scenes/" + mesh["file"].get<std::string>();
  }
  cornell["settings"] = {{"progressive", {{"shooter_points", 8}}}};
  const CliResult s =
      runGuarded("render " + dir.write("c.json", cornell.dump()) +
                 " --method progressive --resume " + progressive + " --dry-run" + out);
  EXPECT_REFUSED(s, 2, "--shooter-points 16, not 8");

  const std::string stochastic = interruptedCheckpoint(dir, "stochastic");
  ASSERT_TRUE(fs::exists(stochastic));
  const std::string sresume = "render cornell --method stochastic --resume " + stochastic;
  for (const auto& [args, needle] :
       {std::pair{sresume + " --seed 9", "was written with --seed 0, not 9"},
        std::pair{sresume + " --shooters 3", "--shooters 1, not 3"},
        std::pair{sresume + " --first-shots 5", "--first-shots 32, not 5"},
        std::pair{"render furnace --method stochastic --resume " + stochastic, "another scene"}}) {
    const CliResult r = runGuarded(args + " --dry-run" + out);
    EXPECT_REFUSED(r, 2, needle);
  }
  same = runGuarded(sresume + " --seed 0 --dry-run" + out);
  EXPECT_EQ(same.exit_code, 0) << same.output;
  EXPECT_FALSE(fs::exists(dir.file("a.png")));
}

// Issue item 13: messages that named no scene, and a work plane outside the scene that gave
// 0 lx in silence.
TEST(HostileValues, MessagesNameTheSceneAndWarnOfAPlaneOutsideIt) {
  TempDir dir;
  const CliResult fit = runGuarded(
      "bake cornell --method progressive --lightmap-size 8 --quiet -o " + dir.file("baked"));
  EXPECT_REFUSED(fit, 2, "cornell: --lightmap-size: the scene's 36 charts do not fit a 8 x 8");
  const CliResult plane = runGuarded(
      "render cornell --width 8 --height 8 --spp 1 --work-plane 1e6 --illuminance-rays 4 -o " +
      dir.file("a.png"));
  EXPECT_EQ(plane.exit_code, 0) << plane.output;
  EXPECT_NE(plane.output.find("warning: --work-plane 1e+06 m lies outside the scene"),
            std::string::npos)
      << plane.output;
}

}  // namespace
}  // namespace penumbra
