// The command-line contract (design doc sec. 4): outputs, stats, the trace file formats, and bad
// input answered by one error line, exit code 2 and no output file.
#include "penumbra/core/file_util.h"
#include "penumbra/io/image_io.h"
#include "penumbra/io/ray_file.h"
#include "support/test_util.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>
#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <thread>

namespace penumbra {
namespace {

namespace fs = std::filesystem;
using test::runCli;
using test::TempDir;

size_t lineCount(const std::string& s) {
  return size_t(std::count(s.begin(), s.end(), '\n')) + (!s.empty() && s.back() != '\n');
}

using test::readJson;

TEST(Cli, RenderFurnaceWritesImagesAndStatsWithTheExactRadiance) {
  TempDir dir;
  const auto r = runCli("render furnace --width 16 --height 16 --spp 128 --quiet -o " +
                        dir.file("f.exr") + " -o " + dir.file("f.pfm") + " -o " +
                        dir.file("f.png") + " --stats " + dir.file("s.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(r.output.empty()) << r.output;  // --quiet
  Expected<Image> exr = readImage(dir.file("f.exr"));
  ASSERT_TRUE(exr.ok()) << exr.error().describe();
  ASSERT_EQ(exr->width, 16);
  double sum = 0.0;
  for (const glm::vec3& p : exr->pixels) sum += p.x + p.y + p.z;
  EXPECT_NEAR(sum / (3.0 * double(exr->pixels.size())), 2.0, 0.03);
  Expected<Image> pfm = readImage(dir.file("f.pfm"));
  ASSERT_TRUE(pfm.ok());
  EXPECT_EQ(pfm->pixels, exr->pixels);  // one render, several files
  EXPECT_TRUE(fs::exists(dir.file("f.png")));
  const nlohmann::json stats = readJson(dir.file("s.json"));
  EXPECT_EQ(stats["method"], "pathtrace");
  EXPECT_EQ(stats["device"], "cpu");
  EXPECT_EQ(stats["spp"], 128);
  EXPECT_GT(stats["rays"].get<double>(), 16.0 * 16.0 * 128.0);
  EXPECT_GT(stats["seconds"].get<double>(), 0.0);
  EXPECT_GT(stats["mrays_per_s"].get<double>(), 0.0);
}

// The two samplers of the path tracer estimate the same image: the Cornell box at 32 x 32 with
// --sampler sobol and independent (16 spp each) against a reference of 512 spp (independent,
// another seed): both means within 2% of it, and Sobol's RMS error per pixel well below the
// independent sampler's. --sampler belongs to pathtrace only.
TEST(Cli, PathTracerSamplersAgreeAndSobolHasLessNoise) {
  TempDir dir;
  const auto render = [&](const std::string& name, const std::string& args) {
    const auto r = runCli("render cornell --width 32 --height 32 --quiet -o " + dir.file(name) +
                          " --stats " + dir.file(name + ".json") + " " + args);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    Expected<Image> img = readImage(dir.file(name));
    EXPECT_TRUE(img.ok());
    return img ? *img : Image{};
  };
  const Image ref = render("ref.pfm", "--spp 512 --sampler independent --seed 7");
  const Image sobol = render("sobol.pfm", "--spp 16");
  const Image indep = render("indep.pfm", "--spp 16 --sampler independent");
  ASSERT_EQ(ref.pixels.size(), sobol.pixels.size());
  double mean_ref = 0, mean_sobol = 0, mean_indep = 0, err_sobol = 0, err_indep = 0;
  for (size_t i = 0; i < ref.pixels.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      mean_ref += ref.pixels[i][c];
      mean_sobol += sobol.pixels[i][c];
      mean_indep += indep.pixels[i][c];
      err_sobol += std::pow(double(sobol.pixels[i][c] - ref.pixels[i][c]), 2.0);
      err_indep += std::pow(double(indep.pixels[i][c] - ref.pixels[i][c]), 2.0);
    }
  }
  EXPECT_NEAR(mean_sobol / mean_ref, 1.0, 0.02);
  EXPECT_NEAR(mean_indep / mean_ref, 1.0, 0.02);
  EXPECT_LT(err_sobol, 0.7 * err_indep) << err_sobol << " vs " << err_indep;
  std::printf("squared error: sobol %g, independent %g\n", err_sobol, err_indep);
  EXPECT_EQ(readJson(dir.file("sobol.pfm.json"))["sampler"], "sobol");
  EXPECT_EQ(readJson(dir.file("indep.pfm.json"))["sampler"], "independent");
  const auto refused =
      runCli("render cornell --method matrix --sampler sobol -o " + dir.file("m.png"));
  EXPECT_EQ(refused.exit_code, 2) << refused.output;
  EXPECT_NE(refused.output.find("--sampler"), std::string::npos) << refused.output;
}

// Matrix radiosity end to end: the furnace's radiance is E / (1 - rho) / pi = 2 in every pixel,
// the stats carry the solver's history, and a relit sequence writes one file per frame.
TEST(Cli, MatrixRadiosityRendersTheFurnaceAndRelitFrames) {
  TempDir dir;
  const auto r = runCli(
      "render furnace --method matrix --elements 200 --width 16 --height 16 "
      "--quiet -o " +
      dir.file("m.pfm") + " --stats " + dir.file("s.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  Expected<Image> img = readImage(dir.file("m.pfm"));
  ASSERT_TRUE(img.ok());
  for (const glm::vec3& p : img->pixels) {
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(p[c], 2.0f, 0.01f);
  }
  const nlohmann::json stats = readJson(dir.file("s.json"));
  EXPECT_EQ(stats["method"], "matrix");
  EXPECT_EQ(stats["solver"], "gauss-seidel");
  EXPECT_EQ(stats["precision"], "fp32");
  EXPECT_TRUE(stats["converged"].get<bool>());
  EXPECT_LE(stats["residual"].get<double>(), 1e-6);
  const auto history = stats["history"].get<std::vector<double>>();
  ASSERT_EQ(history.size(), size_t(stats["iterations"].get<int>()) + 1);
  EXPECT_GT(history.front(), history.back());
  EXPECT_EQ(stats["matrix_bytes"].get<uint64_t>(),
            stats["elements"].get<uint64_t>() * stats["elements"].get<uint64_t>() * 4);

  const auto seq = runCli(
      "render cornell --method matrix --elements 100 --width 8 --height 8 "
      "--relight-frames 3 --quiet -o " +
      dir.file("f.png") + " --stats " + dir.file("r.json"));
  ASSERT_EQ(seq.exit_code, 0) << seq.output;
  for (int f = 0; f < 3; ++f)
    EXPECT_TRUE(fs::exists(dir.file("f_000" + std::to_string(f) + ".png")));
  EXPECT_FALSE(fs::exists(dir.file("f.png")));
  EXPECT_EQ(readJson(dir.file("r.json"))["frames"].size(), 3u);
}

// Progressive radiosity end to end: the furnace's radiance is 2 in every pixel (Wallner's bar,
// every element within 1%), and the stats carry the energy books.
TEST(Cli, ProgressiveRadiosityRendersTheFurnace) {
  TempDir dir;
  const auto r = runCli(
      "render furnace --method progressive --elements 1000 --width 16 "
      "--height 16 --quiet -o " +
      dir.file("p.pfm") + " --stats " + dir.file("s.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  Expected<Image> img = readImage(dir.file("p.pfm"));
  ASSERT_TRUE(img.ok());
  for (const glm::vec3& p : img->pixels) {
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(p[c], 2.0f, 0.02f);
  }
  const nlohmann::json stats = readJson(dir.file("s.json"));
  EXPECT_EQ(stats["method"], "progressive");
  EXPECT_TRUE(stats["converged"].get<bool>());
  EXPECT_LE(stats["unshot_fraction"].get<double>(), 1e-3);
  const auto emitted = stats["emitted_w"].get<std::vector<double>>();
  const auto absorbed = stats["absorbed_w"].get<std::vector<double>>();
  const auto unshot = stats["unshot_w"].get<std::vector<double>>();
  const auto escaped = stats["escaped_w"].get<std::vector<double>>();
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(absorbed[size_t(c)] + unshot[size_t(c)] + escaped[size_t(c)], emitted[size_t(c)],
                1e-9 * emitted[size_t(c)]);
  }
}

// Adaptive subdivision from the command line (Wallner sec. 4): the receivers' statistics, the
// books closed, and thresholds out of order refused with one line naming the options.
TEST(Cli, AdaptiveSubdivisionReportsItsReceivers) {
  TempDir dir;
  const std::string scene = std::string(PENUMBRA_TEST_DATA) + "/../../scenes/slats.json";
  const auto r = runCli("render " + scene +
                        " --method progressive --texel-density 32 --adaptive --receiver-level 3 "
                        "--width 16 --height 16 --quiet -o " +
                        dir.file("p.pfm") + " --stats " + dir.file("s.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json stats = readJson(dir.file("s.json"));
  const nlohmann::json& rec = stats["receivers"];
  EXPECT_TRUE(rec["adaptive"].get<bool>());
  EXPECT_EQ(rec["level"].get<int>(), 3);
  EXPECT_GT(rec["refined"].get<int>(), 20);
  EXPECT_LT(rec["count"].get<int>(), stats["elements"].get<int>() / 4);
  EXPECT_GT(rec["subdivision_share"].get<double>(), 0.0);
  EXPECT_LT(rec["subdivision_share"].get<double>(), 1.0);
  const auto emitted = stats["emitted_w"].get<std::vector<double>>();
  const auto absorbed = stats["absorbed_w"].get<std::vector<double>>();
  const auto unshot = stats["unshot_w"].get<std::vector<double>>();
  const auto escaped = stats["escaped_w"].get<std::vector<double>>();
  EXPECT_NEAR(absorbed[1] + unshot[1] + escaped[1], emitted[1], 1e-9 * emitted[1]);

  const auto bad = runCli("render " + scene +
                          " --method progressive --adaptive --boundary 0.7,0.2 "
                          "--quiet -o " +
                          dir.file("q.pfm"));
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.output.find("--boundary"), std::string::npos) << bad.output;
  EXPECT_EQ(std::count(bad.output.begin(), bad.output.end(), '\n'), 1) << bad.output;
  EXPECT_FALSE(std::filesystem::exists(dir.file("q.pfm")));
}

// Runs the executable with `args` (split on spaces), sends it SIGINT after `delay_s` seconds, and
// returns its exit code (-1 when it did not exit normally). Output goes to /dev/null.
// Runs the CLI and sends it `signal` after `delay_s` seconds; the exit status as a shell gives
// it (128 + the signal's number when the signal ended the process). With `must_exist`, that path
// must exist when the signal is sent (else -2): the run had made it, so it had something to clean.
int runCliSignalled(const std::string& args, double delay_s, int signal,
                    const std::string& must_exist = "");

int runCliInterrupted(const std::string& args, double delay_s) {
  return runCliSignalled(args, delay_s, SIGINT);
}

// Interrupts a run of `args` at 60% of `whole` (the seconds an uninterrupted run took), and
// again earlier (45%, 30%) while a run finishes first (a machine less busy than during the
// timed run). The exit code of the last attempt.
int interruptMidRun(const std::string& args, double whole) {
  int code = 0;
  for (const double share : {0.6, 0.45, 0.3}) {
    code = runCliInterrupted(args, share * whole);
    if (code != 0) break;
  }
  return code;
}

int runCliSignalled(const std::string& args, double delay_s, int signal,
                    const std::string& must_exist) {
  std::vector<std::string> words = {PENUMBRA_CLI};
  for (size_t at = 0; at < args.size();) {
    const size_t end = std::min(args.find(' ', at), args.size());
    if (end > at) words.push_back(args.substr(at, end - at));
    at = end + 1;
  }
  std::vector<char*> argv;
  for (std::string& w : words) argv.push_back(w.data());
  argv.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int null = ::open("/dev/null", O_WRONLY);
    ::dup2(null, 1);
    ::dup2(null, 2);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  if (pid < 0) return -1;
  std::this_thread::sleep_for(std::chrono::duration<double>(delay_s));
  const bool existed = must_exist.empty() || fs::exists(must_exist);
  ::kill(pid, signal);
  int status = 0;
  ::waitpid(pid, &status, 0);
  if (!existed) return -2;
  return WIFEXITED(status)     ? WEXITSTATUS(status)
         : WIFSIGNALED(status) ? 128 + WTERMSIG(status)
                               : -1;
}

std::vector<std::string> entries(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename());
  std::sort(names.begin(), names.end());
  return names;
}

// A command's outputs appear together or not at all: an output that cannot be written is found
// before the work, and nothing else is left.
TEST(Cli, OutputsArePlacedAllOrNothing) {
  TempDir dir;
  const std::string quick = "render cornell --width 8 --height 8 --spp 1 --quiet ";
  // The second output's directory takes no files (/proc): refused up front, the first not
  // written.
  auto r = runCli(quick + "-o " + dir.file("a.png") + " -o /proc/b.png");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("/proc/b.png"), std::string::npos) << r.output;
  r = runCli(quick + "-o " + dir.file("a.png") + " --stats /proc/s.json");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = runCli("trace cornell --rays " + dir.file("none.bin") + " -o " + dir.file("h.bin") +
             " --stats /proc/s.json");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(entries(dir.path()).empty());
  // A 250-byte name is valid (its temporary is short); one longer than the file system allows
  // is refused before the work.
  const std::string long_name = dir.file(std::string(246, 'n') + ".pfm");
  r = runCli(quick + "-o " + long_name);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::exists(long_name));
  r = runCli(quick + "-o " + dir.file(std::string(300, 'n') + ".pfm"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("this file system allows 255"), std::string::npos) << r.output;
  // A bake whose stats cannot be written leaves no output directory.
  r = runCli("bake cornell --method matrix --elements 50 --quiet -o " + dir.file("baked") +
             " --stats /proc/s.json");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_FALSE(fs::exists(dir.file("baked")));
  // A relit sequence's directory is made for it.
  r = runCli(
      "render cornell --method matrix --elements 50 --relight-frames 2 --width 8 "
      "--height 8 --quiet -o " +
      dir.file("frames/c.png"));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(entries(dir.file("frames")), (std::vector<std::string>{"c_0000.png", "c_0001.png"}));
  // Temporaries of a process that no longer exists (killed with SIGKILL) are swept by the next
  // run that writes into the directory.
  dir.write(".penumbra-999999999-0.pfm", "partial");
  r = runCli(quick + "-o " + dir.file("z.pfm"));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_FALSE(fs::exists(dir.file(".penumbra-999999999-0.pfm")));
}

// SIGTERM and SIGINT: where there is a solver to stop (progressive radiosity) the run stops
// cleanly, writes what it has and a checkpoint, and exits with 128 + the signal; elsewhere the
// process ends by the signal and leaves nothing: no temporaries, no staging, no directory it
// made.
TEST(Cli, SignalsLeaveNoDebris) {
  TempDir dir;
  // A matrix bake into a new directory, terminated while it solves.
  const std::string scene_dir = std::string(PENUMBRA_TEST_DATA) + "/../..";
  // A matrix bake into a new directory, ended while it builds and solves: by SIGTERM, and by
  // SIGINT (no solver polls it there). The directory exists when the signal comes.
  const std::string bake = "bake " + scene_dir +
                           "/scenes/room.json --method matrix --elements 3000 -o " +
                           dir.file("out/room");
  int code = runCliSignalled(bake, 1.0, SIGTERM, dir.file("out/room"));
  EXPECT_EQ(code, 128 + SIGTERM);
  EXPECT_TRUE(entries(dir.path()).empty());
  code = runCliSignalled(bake, 0.4, SIGINT, dir.file("out/room"));
  EXPECT_EQ(code, 128 + SIGINT);
  EXPECT_TRUE(entries(dir.path()).empty());
  // Photon mapping ended by Ctrl-C while it shoots or renders: nothing written, exit 130.
  code = runCliSignalled("render " + scene_dir +
                             "/scenes/cornell-glass.json --method photons --photons 20000000 "
                             "--device cpu -o " +
                             dir.file("photons.png"),
                         1.0, SIGINT);
  EXPECT_EQ(code, 128 + SIGINT);
  EXPECT_TRUE(entries(dir.path()).empty());
  // A progressive bake stops cleanly on SIGTERM: outputs and a checkpoint, exit 143, no
  // staging or temporaries.
  code = runCliSignalled(
      "bake cornell --method progressive --texel-density 200 --tolerance "
      "1e-9 --iterations 100000 -o " +
          dir.file("prog"),
      2.0, SIGTERM);
  EXPECT_EQ(code, 143);
  EXPECT_EQ(entries(dir.file("prog")),
            (std::vector<std::string>{"cornell.bin", "cornell.checkpoint", "cornell.gltf",
                                      "cornell_lightmap.exr", "cornell_lightmap.png"}));
}

// Ctrl-C stops progressive radiosity between two iterations: it writes the image of the current
// solution and a checkpoint, exits with 130, and --resume continues to exactly the solution of an
// uninterrupted run (the state is saved in full precision; the shooter order is deterministic).
TEST(Cli, ProgressiveInterruptWritesACheckpointThatResumesExactly) {
  TempDir dir;
  const std::string common =
      "render cornell --method progressive --texel-density 200 --tolerance 1e-9 "
      "--iterations 40 --width 32 --height 32 --spp 1 ";
  const auto full = runCli(common + "--quiet -o " + dir.file("full.pfm"));
  ASSERT_EQ(full.exit_code, 0) << full.output;

  // Late enough that the atlas is built and some shooters have shot even with the other tests
  // of `ctest -j` loading both cores; the uninterrupted run's 40 take about 20 s alone.
  const int code = runCliInterrupted(
      common + "-o " + dir.file("cut.pfm") + " --stats " + dir.file("cut.json"), 4.0);
  ASSERT_EQ(code, 130) << "the run should have been interrupted before its 40 iterations";
  const nlohmann::json cut = readJson(dir.file("cut.json"));
  EXPECT_TRUE(cut["interrupted"].get<bool>());
  const int done = cut["iterations"].get<int>();
  EXPECT_LT(done, 40);
  ASSERT_TRUE(std::filesystem::exists(dir.file("cut.pfm")));
  ASSERT_TRUE(std::filesystem::exists(dir.file("cut.checkpoint")));

  const auto resumed =
      runCli(common + "--quiet --keep-checkpoint --resume " + dir.file("cut.checkpoint") + " -o " +
             dir.file("resumed.pfm") + " --stats " + dir.file("resumed.json"));
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  ASSERT_TRUE(std::filesystem::exists(dir.file("cut.checkpoint")));
  const nlohmann::json rs = readJson(dir.file("resumed.json"));
  EXPECT_EQ(rs["resumed_iterations"].get<int>(), done);
  EXPECT_EQ(rs["iterations"].get<int>(), 40);
  Expected<Image> a = readImage(dir.file("full.pfm"));
  Expected<Image> b = readImage(dir.file("resumed.pfm"));
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(std::memcmp(a->pixels.data(), b->pixels.data(), a->pixels.size() * sizeof(glm::vec3)),
            0);

  // A checkpoint of another scene, or a damaged one, is refused with the file named.
  const auto other = runCli("render furnace --method progressive --resume " +
                            dir.file("cut.checkpoint") + " -o " + dir.file("x.pfm"));
  EXPECT_EQ(other.exit_code, 2);
  EXPECT_NE(other.output.find("another scene"), std::string::npos) << other.output;
  {
    std::string bytes = *readFile(dir.file("cut.checkpoint"));
    bytes[bytes.size() / 2] ^= 0x40;
    dir.write("bad.checkpoint", bytes);
  }
  const auto bad =
      runCli(common + "--resume " + dir.file("bad.checkpoint") + " -o " + dir.file("y.pfm"));
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.output.find("bad.checkpoint"), std::string::npos) << bad.output;
  EXPECT_NE(bad.output.find("corrupt"), std::string::npos) << bad.output;
  EXPECT_FALSE(std::filesystem::exists(dir.file("x.pfm")));
  EXPECT_FALSE(std::filesystem::exists(dir.file("y.pfm")));

  // Without --keep-checkpoint a run that completes removes the checkpoint it continued (its
  // outputs supersede it), once they are in place.
  const auto again = runCli(common + "--quiet --resume " + dir.file("cut.checkpoint") + " -o " +
                            dir.file("again.pfm"));
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_TRUE(std::filesystem::exists(dir.file("again.pfm")));
  EXPECT_FALSE(std::filesystem::exists(dir.file("cut.checkpoint")));
}

// Stochastic radiosity from the command line: the furnace's closed form (B / pi = 2) on average
// over the view, a time limit that stops the iterations, and the stats it reports.
TEST(Cli, StochasticRadiosityRendersTheFurnace) {
  TempDir dir;
  const auto r = runCli(
      "render furnace --method stochastic --texel-density 6 --iterations 400 --width 16 "
      "--height 16 --quiet -o " +
      dir.file("s.pfm") + " --stats " + dir.file("s.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  Expected<Image> img = readImage(dir.file("s.pfm"));
  ASSERT_TRUE(img.ok());
  double mean = 0.0;
  for (const glm::vec3& p : img->pixels) mean += p.y;
  mean /= double(img->pixels.size());
  EXPECT_NEAR(mean, 2.0, 0.04);
  const nlohmann::json stats = readJson(dir.file("s.json"));
  EXPECT_EQ(stats["method"], "stochastic");
  EXPECT_EQ(stats["iterations"].get<int>(), 400);
  EXPECT_EQ(stats["averaged_iterations"].get<int>(), 400 - stats["burn_in"].get<int>());
  EXPECT_GT(stats["error_estimate"].get<double>(), 0.0);
  EXPECT_LT(stats["error_estimate"].get<double>(), 0.2);
  EXPECT_EQ(stats["history"].size(), 400u);

  const auto timed = runCli(
      "render furnace --method stochastic --texel-density 6 --iterations 1000000 --time-limit 0.5 "
      "--width 8 --height 8 --quiet -o " +
      dir.file("t.pfm") + " --stats " + dir.file("t.json"));
  ASSERT_EQ(timed.exit_code, 0) << timed.output;
  const nlohmann::json t = readJson(dir.file("t.json"));
  EXPECT_TRUE(t["timed_out"].get<bool>());
  EXPECT_LT(t["iterations"].get<int>(), 1000000);
  EXPECT_LT(t["solve_seconds"].get<double>(), 1.5);

  const auto bad =
      runCli("render furnace --method progressive --shooters 2 -o " + dir.file("x.pfm"));
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.output.find("--shooters"), std::string::npos) << bad.output;
}

// Relative RMS of image a against b over the lit pixels (not the light itself).
double litRelativeRms(const Image& a, const Image& b) {
  double num = 0.0, den = 0.0;
  for (size_t i = 0; i < b.pixels.size(); ++i) {
    const glm::vec3 p = a.pixels[i], q = b.pixels[i];
    const float l = 0.2126f * q.x + 0.7152f * q.y + 0.0722f * q.z;
    if (!(l > 1e-3f && l < 1.0f)) continue;
    for (int k = 0; k < 3; ++k) {
      num += double(p[k] - q[k]) * double(p[k] - q[k]);
      den += double(q[k]) * double(q[k]);
    }
  }
  return std::sqrt(num / den);
}

// Stochastic radiosity on the GPU end to end. In the furnace nothing occludes, so the GPU draws
// the CPU's random numbers, picks its texels and gives its image for the same seed (to float
// rounding), and the mean over the view is the closed form (B / pi = 2) up to the noise. On the
// Cornell box the iterates part where the depth maps' visibility and the CPU's rays differ (and
// from there the texels the same numbers pick): the GPU's image from a seed is nearer the CPU's
// from that seed than the CPU's from another seed is (the noise of 300 iterations: measured
// 22% against 31%).
TEST(Cli, StochasticRadiosityOnTheGpu) {
  PENUMBRA_GL_OR_SKIP();
  TempDir dir;
  const std::string furnace =
      "render furnace --method stochastic --texel-density 6 --iterations 200 --width 16 "
      "--height 16 --quiet --seed 1 ";
  const auto r =
      runCli(furnace + "--device gpu -o " + dir.file("f.pfm") + " --stats " + dir.file("f.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  ASSERT_EQ(runCli(furnace + "--device cpu -o " + dir.file("fc.pfm")).exit_code, 0);
  Expected<Image> img = readImage(dir.file("f.pfm"));
  Expected<Image> ref = readImage(dir.file("fc.pfm"));
  ASSERT_TRUE(img.ok() && ref.ok());
  double mean = 0.0, worst = 0.0;
  for (size_t i = 0; i < img->pixels.size(); ++i) {
    mean += img->pixels[i].y;
    worst = std::max(worst, double(std::abs(img->pixels[i].y / ref->pixels[i].y - 1.0f)));
  }
  mean /= double(img->pixels.size());
  std::printf(
      "furnace stochastic on the GPU: mean %.4f (2), largest difference from the CPU's "
      "image %.2e\n",
      mean, worst);
  EXPECT_NEAR(mean, 2.0, 0.1);
  EXPECT_LT(worst, 1e-4);
  const nlohmann::json stats = readJson(dir.file("f.json"));
  EXPECT_EQ(stats["device"], "gpu");
  EXPECT_EQ(stats["iterations"].get<int>(), 200);
  EXPECT_GT(stats["error_estimate"].get<double>(), 0.0);
  EXPECT_LT(stats["error_estimate"].get<double>(), 0.2);
  EXPECT_EQ(stats["history"].size(), 200u);

  const std::string cornell =
      "render cornell --method stochastic --elements 3000 --iterations 300 --width 48 "
      "--height 48 --spp 16 --quiet ";
  for (const auto& [args, file] :
       {std::pair{"--seed 5 --device gpu", "g5.pfm"}, std::pair{"--seed 5 --device cpu", "c5.pfm"},
        std::pair{"--seed 6 --device cpu", "c6.pfm"}}) {
    const auto run = runCli(cornell + args + " -o " + dir.file(file));
    ASSERT_EQ(run.exit_code, 0) << run.output;
  }
  Expected<Image> g5 = readImage(dir.file("g5.pfm"));
  Expected<Image> c5 = readImage(dir.file("c5.pfm"));
  Expected<Image> c6 = readImage(dir.file("c6.pfm"));
  ASSERT_TRUE(g5.ok() && c5.ok() && c6.ok());
  const double devices = litRelativeRms(*g5, *c5), seeds = litRelativeRms(*c6, *c5);
  std::printf(
      "cornell stochastic, 300 iterations: GPU against CPU (seed 5) %.4f, CPU seed 6 "
      "against seed 5 %.4f\n",
      devices, seeds);
  EXPECT_LT(devices, seeds);
}

// Subsurface light propagation volumes from the command line: a light orbit of two frames, each
// with its stages' milliseconds (Table 1's columns), and an animated mesh that changes topology.
TEST(Cli, LpvRendersFramesWithTheirStageTimes) {
  TempDir dir;
  const auto r = runCli(
      "render lpv --method lpv --frames 2 --width 48 --height 48 --spp 1 "
      "--quiet -o " +
      dir.file("f.png") + " --stats " + dir.file("s.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(std::filesystem::exists(dir.file("f_0000.png")));
  EXPECT_TRUE(std::filesystem::exists(dir.file("f_0001.png")));
  const nlohmann::json s = readJson(dir.file("s.json"));
  EXPECT_EQ(s["method"], "lpv");
  EXPECT_EQ(s["grid"].get<int>(), 32);
  ASSERT_EQ(s["frames"].size(), 2u);
  for (const nlohmann::json& f : s["frames"]) {
    for (const char* stage : {"voxelise_ms", "inject_ms", "propagate_ms", "shade_ms"}) {
      EXPECT_GT(f[stage].get<double>(), 0.0) << stage;
    }
    EXPECT_GT(f["rsm_texels"].get<int>(), 1000);
  }
  ASSERT_EQ(s["objects"].size(), 1u);
  EXPECT_GT(s["objects"][0]["inside_cells"].get<int>(), 1000);
  EXPECT_GT(s["objects"][0]["boundary_cells"].get<int>(), 1000);

  // The animated `blobs` remesh every frame (two blobs merging): nothing is precomputed, so
  // the method follows the changing mesh.
  const auto b = runCli(
      "render blobs --method lpv --frames 3 --width 32 --height 24 --spp 1 "
      "--quiet -o " +
      dir.file("b.png") + " --stats " + dir.file("b.json"));
  ASSERT_EQ(b.exit_code, 0) << b.output;
  const nlohmann::json bs = readJson(dir.file("b.json"));
  ASSERT_EQ(bs["frames"].size(), 3u);
  EXPECT_NE(bs["frames"][0]["triangles"], bs["frames"][2]["triangles"]);
  EXPECT_TRUE(std::filesystem::exists(dir.file("b_0002.png")));
}

// `--device gpu` propagates on the GPU: the frames (lights orbiting) are the CPU's images to float
// rounding; `hybrid` is refused.
TEST(Cli, LpvOnTheGpu) {
  PENUMBRA_GL_OR_SKIP();
  TempDir dir;
  const std::string common =
      "render lpv --method lpv --frames 2 --width 32 --height 32 --spp 1 --rsm-resolution 64 "
      "--quiet ";
  const auto r =
      runCli(common + "--device gpu -o " + dir.file("g.pfm") + " --stats " + dir.file("g.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  ASSERT_EQ(runCli(common + "--device cpu -o " + dir.file("c.pfm")).exit_code, 0);
  for (const char* frame : {"_0000.pfm", "_0001.pfm"}) {
    Expected<Image> gpu = readImage(dir.file(std::string("g") + frame));
    Expected<Image> cpu = readImage(dir.file(std::string("c") + frame));
    ASSERT_TRUE(gpu.ok() && cpu.ok());
    double diff = 0.0, sum = 0.0;
    for (size_t i = 0; i < gpu->pixels.size(); ++i) {
      diff += std::abs(double(gpu->pixels[i].x) - double(cpu->pixels[i].x));
      sum += cpu->pixels[i].x;
    }
    std::printf("lpv frame %s: GPU vs CPU %.2e relative\n", frame, diff / sum);
    EXPECT_GT(sum, 0.0);
    EXPECT_LT(diff / sum, 1e-5);
  }
  EXPECT_EQ(readJson(dir.file("g.json"))["device"], "gpu");
  const auto h = runCli(common + "--device hybrid -o " + dir.file("h.png"));
  EXPECT_EQ(h.exit_code, 2);
  EXPECT_NE(h.output.find("--device"), std::string::npos) << h.output;
}

// Ctrl-C keeps the estimate so far (the image and a checkpoint), and --resume continues it to
// exactly the image of the uninterrupted run.
TEST(Cli, StochasticInterruptWritesACheckpointThatResumesExactly) {
  TempDir dir;
  const std::string common =
      "render cornell --method stochastic --elements 10000 --iterations 4000 --width 16 --height "
      "16 "
      "--spp 1 ";
  const auto start = std::chrono::steady_clock::now();
  const auto full = runCli(common + "--quiet -o " + dir.file("full.pfm"));
  ASSERT_EQ(full.exit_code, 0) << full.output;
  // The signal lands in the iterations, after the lightmap is built, on a machine of any speed
  // (under AddressSanitizer too): at 60% of the whole run's time (earlier if that was too late).
  const double whole =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const int code = interruptMidRun(
      common + "-o " + dir.file("cut.pfm") + " --stats " + dir.file("cut.json"), whole);
  ASSERT_EQ(code, 130) << "the run should have been interrupted before its 4000 iterations";
  const nlohmann::json cut = readJson(dir.file("cut.json"));
  EXPECT_TRUE(cut["interrupted"].get<bool>());
  const int done = cut["iterations"].get<int>();
  EXPECT_LT(done, 4000);
  ASSERT_TRUE(std::filesystem::exists(dir.file("cut.pfm")));
  ASSERT_TRUE(std::filesystem::exists(dir.file("cut.checkpoint")));
  const auto resumed = runCli(common + "--quiet --resume " + dir.file("cut.checkpoint") + " -o " +
                              dir.file("resumed.pfm") + " --stats " + dir.file("resumed.json"));
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  EXPECT_FALSE(std::filesystem::exists(dir.file("cut.checkpoint")));
  const nlohmann::json rs = readJson(dir.file("resumed.json"));
  EXPECT_EQ(rs["resumed_iterations"].get<int>(), done);
  EXPECT_EQ(rs["iterations"].get<int>(), 4000);
  Expected<Image> a = readImage(dir.file("full.pfm"));
  Expected<Image> b = readImage(dir.file("resumed.pfm"));
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(std::memcmp(a->pixels.data(), b->pixels.data(), a->pixels.size() * sizeof(glm::vec3)),
            0);
  // A progressive checkpoint is not a stochastic one.
  const auto wrong = runCli("render cornell --method stochastic --resume " +
                            dir.file("resumed.json") + " -o " + dir.file("w.pfm"));
  EXPECT_EQ(wrong.exit_code, 2);
  EXPECT_NE(wrong.output.find("not a Penumbra stochastic radiosity checkpoint"), std::string::npos)
      << wrong.output;
}

TEST(Cli, BakeStochasticWritesTheAverageAsALightmap) {
  TempDir dir;
  const auto r = runCli("bake cornell --method stochastic --iterations 60 --seed 3 --quiet -o " +
                        dir.file("out") + " --stats " + dir.file("s.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(std::filesystem::exists(dir.file("out/cornell.gltf")));
  EXPECT_TRUE(std::filesystem::exists(dir.file("out/cornell_lightmap.exr")));
  const nlohmann::json stats = readJson(dir.file("s.json"));
  EXPECT_EQ(stats["method"], "stochastic");
  EXPECT_EQ(stats["seed"].get<uint64_t>(), 3u);
  EXPECT_EQ(stats["iterations"].get<int>(), 60);
  const auto bad = runCli("bake cornell --method matrix --seed 3 -o " + dir.file("m"));
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.output.find("--seed"), std::string::npos) << bad.output;
}

TEST(Cli, SceneSettingsApplyAndCommandLineWins) {
  TempDir dir;
  const std::string cornell = std::string(PENUMBRA_TEST_DATA) + "/../../scenes/cornell.json";
  std::ifstream in(cornell);
  nlohmann::json scene = nlohmann::json::parse(in, nullptr, true, true);
  scene["settings"] = {{"pathtrace", {{"width", 8}, {"height", 6}, {"spp", 2}}}};
  // Paths in the scene are relative to it: keep the copy beside the original's meshes.
  for (auto& m : scene["meshes"]) {
    m["file"] = (fs::path(cornell).parent_path() / m["file"].get<std::string>()).string();
  }
  const std::string path = dir.write("scene.json", scene.dump());
  const auto r = runCli(path + " --quiet -o " + dir.file("a.pfm") + " --height 4");
  // `render` is required; the scene alone is not a command.
  EXPECT_EQ(r.exit_code, 2);
  const auto ok = runCli("render " + path + " --quiet -o " + dir.file("a.pfm") + " --height 4");
  ASSERT_EQ(ok.exit_code, 0) << ok.output;
  Expected<Image> img = readImage(dir.file("a.pfm"));
  ASSERT_TRUE(img.ok());
  EXPECT_EQ(img->width, 8);
  EXPECT_EQ(img->height, 4);

  scene["settings"]["pathtrace"]["sppp"] = 3;  // a misspelt setting is an error
  const std::string bad = dir.write("bad.json", scene.dump());
  const auto err = runCli("render " + bad + " --quiet -o " + dir.file("b.pfm"));
  EXPECT_EQ(err.exit_code, 2);
  EXPECT_NE(err.output.find("settings.pathtrace.sppp"), std::string::npos) << err.output;
  EXPECT_FALSE(fs::exists(dir.file("b.pfm")));
  // A value out of range names the file, the key and the value (2^40 does not wrap).
  scene["settings"]["pathtrace"].erase("sppp");
  scene["settings"]["pathtrace"]["spp"] = uint64_t(1) << 40;
  const std::string big = dir.write("big.json", scene.dump());
  const auto range = runCli("render " + big + " --quiet -o " + dir.file("c.pfm"));
  EXPECT_EQ(range.exit_code, 2);
  EXPECT_NE(range.output.find("big.json: settings.pathtrace.spp: 1099511627776 is out of range"),
            std::string::npos)
      << range.output;
  EXPECT_FALSE(fs::exists(dir.file("c.pfm")));
}

struct BadCase {
  std::string args;
  std::string expect;  // a fragment the error line must contain
};

TEST(Cli, BadInputGivesOneErrorLineExitTwoAndNoOutput) {
  TempDir dir;
  const std::string out = dir.file("out.png");
  dir.write("broken.json", "{\n  \"meshes\": [\n    {\"file\": \"x.obj\",}\n  ]\n}\n");
  dir.write("unknown_key.json", "{\"meshs\": []}");
  dir.write("nan.obj", "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n");
  dir.write("badindex.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n");
  dir.write("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  // A light at 1e39 (inf as a float) crashed pathtrace, progressive and whitted and made NaN
  // images with the other methods; one of 1e300 W/sr made inf pixels.
  dir.write("far_light.json", R"({"meshes": [{"file": "tri.obj"}],
      "lights": [{"type": "point", "position": [1e39, 0.3, 0.3], "intensity": [1, 1, 1]}]})");
  dir.write("hot_light.json", R"({"meshes": [{"file": "tri.obj"}],
      "lights": [{"type": "point", "position": [0.2, 0.2, 1], "intensity": [1e300, 1, 1]}]})");
  std::vector<BadCase> cases = {
      {"render nosuchscene -o " + out, "unknown scene 'nosuchscene'"},
      {"render " + dir.file("missing.obj") + " -o " + out, "missing.obj"},
      {"render " + dir.file("broken.json") + " -o " + out, "broken.json: line 3"},
      {"render " + dir.file("unknown_key.json") + " -o " + out, "meshs"},
      {"render " + dir.file("nan.obj") + " -o " + out, "nan.obj: line 2"},
      {"render " + dir.file("badindex.obj") + " -o " + out, "badindex.obj: line 4"},
      {"render cornell --width 0 -o " + out, "--width: 0 is out of range [1, 65536]"},
      {"render cornell --width 60000 --height 60000 -o " + out, "needs"},
      {"render cornell --spp many -o " + out, "spp"},
      {"render cornell --method lpv -o " + out, "no translucent material"},
      {"render lpv --method lpv --skip-steps 8 --steps 8 -o " + out, "--skip-steps"},
      {"render lpv --method lpv --device hybrid -o " + out, "--device"},
      {"render lpv --method lpv --surface-rays 257 -o " + out, "--surface-rays"},
      {"render cornell --method pathtrace --grid 32 -o " + out, "--grid"},
      {"render cornell --method matrix --frames 3 -o " + out, "--frames"},
      {"render cornell --method stochastic --elements 268435456 -o " + out,
       "stochastic radiosity with 268435456 lightmap texels"},
      {"render cornell --method stochastic --device hybrid -o " + out, "hybrid"},
      {"render cornell --method pathtrace --shooters 2 -o " + out, "--shooters"},
      {"render cornell --method progressive --tolerance 2 -o " + out, "--tolerance"},
      {"render cornell --method progressive --elements 268435456 -o " + out,
       "progressive radiosity with 268435456 lightmap texels"},
      {"render cornell --method progressive --device hybrid -o " + out, "hybrid"},
      {"render cornell --method pathtrace --texel-density 10 -o " + out, "--texel-density"},
      {"render cornell --method progressive --texel-density -1 -o " + out, "--texel-density"},
      // So coarse that charts get no texel: an internal check stopped it (exit 1, SIGABRT in
      // the viewer).
      {"render cornell --method progressive --texel-density 3e-4 --quiet -o " + out,
       "lightmap: 0.0003 texels per metre leave chart"},
      {"render cornell --method stochastic --texel-density 3e-4 --quiet -o " + out,
       "without a texel"},
      // The density sizes the plan: refused before anything is built.
      {"render cornell --method progressive --texel-density 3000 -o " + out,
       "lightmap texels (--texel-density) needs"},
      {"bake cornell --method progressive --texel-density 3000 -o " + dir.file("bk"),
       "(--texel-density) needs"},
      {"render cornell --method progressive --resume " + out + ".nope -o " + out, ".nope"},
      {"render cornell --method matrix --elements 0 -o " + out, "--elements"},
      {"render cornell --method matrix --solver sor -o " + out, "--solver"},
      {"render cornell --method matrix --precision fp8 -o " + out, "--precision"},
      {"render cornell --method matrix --max-depth 3 -o " + out, "--max-depth"},
      {"render cornell --method matrix --elements 1000000 -o " + out, "needs"},
      {"render cornell --method nonsense -o " + out, "unknown --method"},
      {"render cornell --device tpu -o " + out, "--device"},
      {"render cornell --frobnicate -o " + out, "frobnicate"},
      {"render cornell -o " + dir.file("out.bmp"), "unsupported image format '.bmp'"},
      {"render cornell -o " + dir.file("nodir/out.png"), "does not exist"},
      {"render cornell --tonemap sepia -o " + out, "tonemap"},
      {"render cornell --key 0 -o " + out, "--key: 0 is out of range (0, 1]"},
      {"render cornell --key -1 -o " + out, "--key: -1 is out of range"},
      {"render cornell --key nan -o " + out, "--key: 'nan' is not a finite number"},
      {"render cornell --exposure inf -o " + out, "--exposure: 'inf' is not a finite number"},
      {"render cornell --method matrix --tolerance nan -o " + out, "--tolerance: 'nan'"},
      {"render cornell --method progressive --tolerance 0 -o " + out, "--tolerance: 0 is out"},
      {"render cornell --seed -1 -o " + out, "--seed: '-1' is not a non-negative integer"},
      {"render cornell --seed 18446744073709551616 -o " + out, "larger than 2^64 - 1"},
      {"render cornell --spp '' -o " + out, "--spp: an empty value is not allowed"},
      {"bake cornell --texel-density nan -o " + dir.file("bakedir"), "--texel-density: 'nan'"},
      {"info nosuchscene", "unknown scene"},
      {"trace cornell --rays " + dir.file("none.bin") + " -o " + dir.file("hits.bin"), "none.bin"},
      {"trace cornell --rays " + dir.file("none.bin") + " -o " + dir.file("hits.bin") +
           " --device hybrid --r-min 64 --cache-rays 32",
       "--cache-rays 32 is smaller than --r-min 64"},
      {"trace cornell --rays " + dir.file("none.bin") + " -o " + dir.file("hits.bin") +
           " --cache-rays 0",
       "--cache-rays"},
      {"trace cornell --rays " + dir.file("none.bin") + " -o " + dir.file("hits.bin") +
           " --cache-rays lots",
       "--cache-rays"},
      {"frobnicate", "unknown command 'frobnicate'"},
  };
  for (const char* method :
       {"pathtrace", "whitted", "photons", "matrix", "progressive", "stochastic"}) {
    cases.push_back({"render " + dir.file("far_light.json") + " --method " + method + " -o " + out,
                     "far_light.json: light 0 (point): position (inf, 0.3, 0.3) must be finite"});
    cases.push_back(
        {"render " + dir.file("hot_light.json") + " --method " + method + " --dry-run -o " + out,
         "hot_light.json: light 0 (point): intensity (inf, 1, 1) must be finite"});
  }
  for (const BadCase& c : cases) {
    const auto r = runCli(c.args);
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.output;
    EXPECT_EQ(lineCount(r.output), 1u) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find("error"), std::string::npos) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.expect), std::string::npos) << c.args << "\n" << r.output;
  }
  // Nothing was written: only the inputs are in the directory.
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir.path())) names.push_back(e.path().filename());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names,
            (std::vector<std::string>{"badindex.obj", "broken.json", "far_light.json",
                                      "hot_light.json", "nan.obj", "tri.obj", "unknown_key.json"}));
}

// A unit square in z = 0 as two triangles: (0,0) (1,0) (1,1) and (0,0) (1,1) (0,1).
std::string writeSquare(const TempDir& dir) {
  return dir.write("square.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
}

TEST(Cli, TraceFollowsTheFileContract) {
  TempDir dir;
  const std::string mesh = writeSquare(dir);
  RayBatch rays;
  rays.resize(4);
  const float inf = std::numeric_limits<float>::infinity();
  rays.set(0, Ray{{0.75f, 0.25f, 2.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, inf});   // triangle 0
  rays.set(1, Ray{{0.25f, 0.75f, -1.0f}, 0.0f, {0.0f, 0.0f, 2.0f}, inf});   // triangle 1, t=0.5
  rays.set(2, Ray{{2.0f, 2.0f, 1.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, inf});     // miss
  rays.set(3, Ray{{0.75f, 0.25f, 2.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, 1.5f});  // beyond tmax
  ASSERT_TRUE(writeRayFile(dir.file("rays.bin"), rays).ok());
  const auto r = runCli("trace " + mesh + " --rays " + dir.file("rays.bin") + " -o " +
                        dir.file("hits.bin") + " --stats " + dir.file("t.json") + " --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  ASSERT_EQ(fs::file_size(dir.file("hits.bin")), 4u * 16u);
  Expected<HitBatch> hits = readHitFile(dir.file("hits.bin"));
  ASSERT_TRUE(hits.ok());
  EXPECT_EQ(hits->triangle[0], 0);
  EXPECT_FLOAT_EQ(hits->t[0], 2.0f);
  // Barycentrics of vertices 1 and 2 of triangle 0: p = (1-u-v)(0,0) + u(1,0) + v(1,1).
  EXPECT_FLOAT_EQ(hits->u[0], 0.5f);
  EXPECT_FLOAT_EQ(hits->v[0], 0.25f);
  EXPECT_EQ(hits->triangle[1], 1);
  EXPECT_FLOAT_EQ(hits->t[1], 0.5f);
  EXPECT_EQ(hits->triangle[2], -1);
  EXPECT_TRUE(std::isinf(hits->t[2]));
  EXPECT_EQ(hits->triangle[3], -1);
  const nlohmann::json stats = readJson(dir.file("t.json"));
  for (const char* key : {"build_seconds", "trace_seconds", "mrays_per_s", "seconds"}) {
    EXPECT_TRUE(stats.contains(key)) << key;
  }
  EXPECT_EQ(stats["rays"], 4);
  EXPECT_EQ(stats["hits"], 2);
  EXPECT_EQ(stats["triangles"], 2);
}

// Shadow rays: one byte per ray, 1 exactly when a closest hit exists within [tmin, tmax], on
// the CPU and through the GPU's closest hits.
TEST(Cli, TraceOcclusionWritesOneBytePerRay) {
  TempDir dir;
  const std::string mesh = writeSquare(dir);
  RayBatch rays;
  rays.resize(5);
  const float inf = std::numeric_limits<float>::infinity();
  rays.set(0, Ray{{0.75f, 0.25f, 2.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, inf});   // blocked
  rays.set(1, Ray{{0.25f, 0.75f, -1.0f}, 0.0f, {0.0f, 0.0f, 2.0f}, 0.6f});  // blocked at 0.5
  rays.set(2, Ray{{2.0f, 2.0f, 1.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, inf});     // miss
  rays.set(3, Ray{{0.75f, 0.25f, 2.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, 1.5f});  // short of it
  rays.set(4, Ray{{0.75f, 0.25f, 2.0f}, 2.5f, {0.0f, 0.0f, -1.0f}, inf});   // starts past it
  ASSERT_TRUE(writeRayFile(dir.file("rays.bin"), rays).ok());
  const auto r =
      runCli("trace " + mesh + " --rays " + dir.file("rays.bin") + " -o " + dir.file("occ.bin") +
             " --occlusion --device cpu --stats " + dir.file("o.json") + " --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(*readFile(dir.file("occ.bin")), std::string("\x01\x01\x00\x00\x00", 5));
  const nlohmann::json stats = readJson(dir.file("o.json"));
  EXPECT_EQ(stats["method"], "trace-occlusion");
  EXPECT_EQ(stats["hits"], 2);
}

TEST(Cli, TraceRejectsMalformedRayFiles) {
  TempDir dir;
  const std::string mesh = writeSquare(dir);
  const std::string hits = dir.file("hits.bin");
  dir.write("short.bin", std::string(40, '\0'));
  RayBatch rays;
  rays.resize(2);
  rays.set(0, Ray{{0, 0, 1}, 0.0f, {0, 0, -1}, 10.0f});
  rays.set(1, Ray{{0, std::nanf(""), 1}, 0.0f, {0, 0, -1}, 10.0f});
  ASSERT_TRUE(writeRayFile(dir.file("nan.bin"), rays).ok());
  rays.set(1, Ray{{0, 0, 1}, 0.0f, {0, 0, 0}, 10.0f});
  ASSERT_TRUE(writeRayFile(dir.file("zero.bin"), rays).ok());
  const std::vector<BadCase> cases = {
      {"short.bin", "not a multiple of 32"},
      {"nan.bin", "nan.bin: ray 1: origin is not finite"},
      {"zero.bin", "zero.bin: ray 1: direction is zero"},
  };
  for (const BadCase& c : cases) {
    const auto r = runCli("trace " + mesh + " --rays " + dir.file(c.args) + " -o " + hits);
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_EQ(lineCount(r.output), 1u) << r.output;
    EXPECT_NE(r.output.find(c.expect), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(hits));
  }
}

// Progressive radiosity on the GPU (Wallner sec. 3: hemispherical depth maps, the receivers
// rasterised into the lightmap, the gap-filling post-process) end to end: the furnace's radiance
// is 2 in every pixel, and the Cornell box's image agrees with the CPU's (which shoots with its
// hierarchical substructuring and ray-traced visibility: a different discretisation).
TEST(Cli, ProgressiveRadiosityOnTheGpu) {
  PENUMBRA_GL_OR_SKIP();
  TempDir dir;
  const auto furnace = runCli(
      "render furnace --method progressive --device gpu --elements 1000 --width 16 "
      "--height 16 --quiet -o " +
      dir.file("f.pfm") + " --stats " + dir.file("f.json"));
  ASSERT_EQ(furnace.exit_code, 0) << furnace.output;
  Expected<Image> f = readImage(dir.file("f.pfm"));
  ASSERT_TRUE(f.ok());
  for (const glm::vec3& p : f->pixels) {
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(p[c], 2.0f, 0.02f);
  }
  const nlohmann::json fs = readJson(dir.file("f.json"));
  EXPECT_EQ(fs["device"], "gpu");
  EXPECT_TRUE(fs["converged"].get<bool>());

  const std::string common =
      "render cornell --method progressive --elements 1500 --width 48 "
      "--height 48 --spp 16 --quiet ";
  const auto gpu = runCli(common + "--device gpu -o " + dir.file("g.pfm"));
  const auto cpu = runCli(common + "--device cpu -o " + dir.file("c.pfm"));
  ASSERT_EQ(gpu.exit_code, 0) << gpu.output;
  ASSERT_EQ(cpu.exit_code, 0) << cpu.output;
  Expected<Image> g = readImage(dir.file("g.pfm"));
  Expected<Image> c = readImage(dir.file("c.pfm"));
  ASSERT_TRUE(g.ok() && c.ok());
  double num = 0.0, den = 0.0;
  for (size_t i = 0; i < c->pixels.size(); ++i) {
    const glm::vec3 a = g->pixels[i], b = c->pixels[i];
    const float l = 0.2126f * b.x + 0.7152f * b.y + 0.0722f * b.z;
    if (!(l > 1e-3f && l < 1.0f)) continue;  // lit, not the light itself
    for (int k = 0; k < 3; ++k) {
      num += double(a[k] - b[k]) * double(a[k] - b[k]);
      den += double(b[k]) * double(b[k]);
    }
  }
  const double rms = std::sqrt(num / den);
  std::printf("cornell, GPU against CPU image: relative RMS %.4f\n", rms);
  // Measured 8.6% here (1,500 elements over both sides of every surface, 48 x 48): the GPU's
  // depth-map visibility (Fig. 3's neighbourhood at shadow boundaries and in concave corners, the
  // interpolated depth of sub-triangles) against the CPU's rays; 2.2% when every element was on
  // one side only (twice the texels per side). Per shot from the same state the two agree to
  // 0.85% RMS (ProgressiveGl.MatchesTheCpuOnTheCornellBox).
  EXPECT_LE(rms, 0.10);
}

// EGL with no vendor library: no context can be made.
const char* kNoGl = "__EGL_VENDOR_LIBRARY_FILENAMES=/nonexistent.json";

TEST(Cli, TraceOnTheGpuGivesTheCpuAnswers) {
  PENUMBRA_GL_OR_SKIP();
  TempDir dir;
  RayBatch rays;
  rays.resize(2000);
  for (size_t i = 0; i < rays.size(); ++i) {
    const float a = 0.001f * float(i);
    rays.set(i, Ray{{-0.02f + 0.05f * std::cos(a * 7.0f), 0.11f + 0.05f * std::sin(a * 5.0f), 0.5f},
                    0.0f,
                    {0.1f * std::sin(a), 0.05f * std::cos(a * 3.0f), -1.0f},
                    10.0f});
  }
  ASSERT_TRUE(writeRayFile(dir.file("rays.bin"), rays).ok());
  const std::string bunny = test::dataPath("bunny.ply");
  const auto cpu = runCli("trace " + bunny + " --rays " + dir.file("rays.bin") + " -o " +
                          dir.file("cpu.bin") + " --device cpu --quiet");
  const auto gpu = runCli("trace " + bunny + " --rays " + dir.file("rays.bin") + " -o " +
                          dir.file("gpu.bin") + " --device gpu --stats " + dir.file("g.json"));
  ASSERT_EQ(cpu.exit_code, 0) << cpu.output;
  ASSERT_EQ(gpu.exit_code, 0) << gpu.output;
  EXPECT_NE(gpu.output.find("device: gpu"), std::string::npos) << gpu.output;
  Expected<HitBatch> a = readHitFile(dir.file("cpu.bin"));
  Expected<HitBatch> b = readHitFile(dir.file("gpu.bin"));
  ASSERT_TRUE(a.ok() && b.ok());
  size_t hits = 0, same = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    ASSERT_EQ(a->triangle[i] >= 0, b->triangle[i] >= 0) << i;
    if (a->triangle[i] < 0) continue;
    ++hits;
    same += a->triangle[i] == b->triangle[i];
    EXPECT_NEAR(b->t[i], a->t[i], 1e-5f * a->t[i]) << i;
  }
  EXPECT_GT(hits, 500u);
  EXPECT_GE(same, hits - 2);  // only true ties may differ
  EXPECT_EQ(readJson(dir.file("g.json"))["device"], "gpu");

  // Occlusion through the GPU's closest hits: a byte for each ray the CPU saw hit.
  const auto occ = runCli("trace " + bunny + " --rays " + dir.file("rays.bin") + " -o " +
                          dir.file("occ.bin") + " --device gpu --occlusion --quiet");
  ASSERT_EQ(occ.exit_code, 0) << occ.output;
  const std::string bytes = *readFile(dir.file("occ.bin"));
  ASSERT_EQ(bytes.size(), rays.size());
  for (size_t i = 0; i < rays.size(); ++i) ASSERT_EQ(bytes[i] == 1, a->triangle[i] >= 0) << i;

  // The CPU/GPU split gives the same answers too.
  const auto hybrid =
      runCli("trace " + bunny + " --rays " + dir.file("rays.bin") + " -o " +
             dir.file("hybrid.bin") + " --device hybrid --t-min 32 --t-max 256 --r-min 16 " +
             "--cache-rays 128 --quiet --stats " + dir.file("h.json"));
  ASSERT_EQ(hybrid.exit_code, 0) << hybrid.output;
  Expected<HitBatch> c = readHitFile(dir.file("hybrid.bin"));
  ASSERT_TRUE(c.ok());
  size_t same_hybrid = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    ASSERT_EQ(a->triangle[i] >= 0, c->triangle[i] >= 0) << i;
    if (a->triangle[i] < 0) continue;
    same_hybrid += a->triangle[i] == c->triangle[i];
    EXPECT_NEAR(c->t[i], a->t[i], std::max(1e-5f * a->t[i], 1e-7f)) << i;
  }
  EXPECT_GE(same_hybrid, hits - 2);
  const nlohmann::json hs = readJson(dir.file("h.json"));
  EXPECT_EQ(hs["device"], "hybrid");
  EXPECT_GT(hs["hybrid"]["gpu_cells"].get<int>(), 0);
  EXPECT_EQ(hs["hybrid"]["r_min"], 16);
  EXPECT_EQ(hs["hybrid"]["cache_rays"], 128);
  EXPECT_GT(hs["hybrid"]["gpu_batches"].get<int>(), 0);
  EXPECT_GT(hs["hybrid"]["gpu_triangles"].get<int>(), 0);
  EXPECT_GT(hs["hybrid"]["gpu_triangles_culled"].get<int>(), 0);
  EXPECT_LT(hs["hybrid"]["gpu_triangles_culled"].get<int>(),
            hs["hybrid"]["gpu_triangles"].get<int>());
}

TEST(Cli, RenderOnTheGpuAndHybridGivesTheCpuImage) {
  PENUMBRA_GL_OR_SKIP();
  TempDir dir;
  const std::string common = "render cornell --width 16 --height 12 --spp 4 --seed 3 --quiet ";
  for (const std::string device : {"cpu", "gpu", "hybrid"}) {
    const auto r = runCli(common + "--device " + device + " -o " + dir.file(device + ".pfm") +
                          " --stats " + dir.file(device + ".json"));
    ASSERT_EQ(r.exit_code, 0) << device << ": " << r.output;
    EXPECT_EQ(readJson(dir.file(device + ".json"))["device"], device);
  }
  Expected<Image> cpu = readImage(dir.file("cpu.pfm"));
  ASSERT_TRUE(cpu.ok());
  for (const std::string device : {"gpu", "hybrid"}) {
    Expected<Image> other = readImage(dir.file(device + ".pfm"));
    ASSERT_TRUE(other.ok());
    double err = 0.0, norm = 0.0;
    for (size_t i = 0; i < cpu->pixels.size(); ++i) {
      const glm::vec3 d = other->pixels[i] - cpu->pixels[i];
      err += double(glm::dot(d, d));
      norm += double(glm::dot(cpu->pixels[i], cpu->pixels[i]));
    }
    EXPECT_LT(std::sqrt(err / norm), 1e-4) << device;
  }
}

TEST(Cli, DeviceGpuWithoutAContextIsAClearErrorAndAutoFallsBack) {
  TempDir dir;
  const std::string mesh = dir.write("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  RayBatch rays;
  rays.resize(1);
  rays.set(0, Ray{{0.2f, 0.2f, 1.0f}, 0.0f, {0, 0, -1}, 10.0f});
  ASSERT_TRUE(writeRayFile(dir.file("rays.bin"), rays).ok());
  const std::string args =
      "trace " + mesh + " --rays " + dir.file("rays.bin") + " -o " + dir.file("hits.bin");
  const auto gpu = runCli(args + " --device gpu", kNoGl);
  EXPECT_EQ(gpu.exit_code, 2) << gpu.output;
  EXPECT_EQ(lineCount(gpu.output), 1u) << gpu.output;
  EXPECT_NE(gpu.output.find("--device gpu: no OpenGL 4.5 context could be made"), std::string::npos)
      << gpu.output;
  EXPECT_FALSE(fs::exists(dir.file("hits.bin")));
  const auto autod = runCli(args + " --device auto", kNoGl);
  EXPECT_EQ(autod.exit_code, 0) << autod.output;
  EXPECT_NE(autod.output.find("device: cpu (no GPU"), std::string::npos) << autod.output;
  Expected<HitBatch> hits = readHitFile(dir.file("hits.bin"));
  ASSERT_TRUE(hits.ok());
  EXPECT_EQ(hits->triangle[0], 0);
}

TEST(Cli, InfoDevicesListsContextsAndTheirLimits) {
  const auto none = runCli("info --devices", kNoGl);
  EXPECT_EQ(none.exit_code, 0);
  EXPECT_NE(none.output.find("gpu        none"), std::string::npos) << none.output;
  PENUMBRA_GL_OR_SKIP();
  const auto r = runCli("info --devices");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.output.find("4.5"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("max shader storage block"), std::string::npos) << r.output;
}

// A warning is given once: --sky and --scale check the scene again, and its load already said
// which triangles are degenerate.
TEST(Cli, TheLoadsWarningsAreGivenOnceWhateverLightsTheScene) {
  TempDir dir;
  const std::string obj = dir.write("floor.obj",
                                    "v -1 0 -1\nv -1 0 1\nv 1 0 1\nv 1 0 -1\nv 2 0 2\n"
                                    "f 1 2 3\nf 1 3 4\nf 5 5 5\n");
  for (const char* light :
       {"--sky overcast", "--environment 1,1,1", "--environment 1,1,1 --scale 2"}) {
    SCOPED_TRACE(light);
    const auto r = runCli("render " + obj + " " + light + " --width 8 --height 8 --spp 1 -o " +
                          dir.file("x.png"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    size_t count = 0;
    for (size_t at = r.output.find("degenerate"); at != std::string::npos;
         at = r.output.find("degenerate", at + 1)) {
      ++count;
    }
    EXPECT_EQ(count, 1u) << r.output;
  }
}

// Under a uniform environment of radiance L (and nothing else), an open plane's work plane gets
// E = pi L at every point (683 lm/W): in every method's lux, the radiosity methods' included
// (their rays that leave the scene find no lightmap; they see the environment).
TEST(Cli, LuxUnderAnEnvironmentIsPiLInEveryMethod) {
  TempDir dir;
  const std::string obj =
      dir.write("plane.obj", "v -5 0 -5\nv -5 0 5\nv 5 0 5\nv 5 0 -5\nf 1 2 3\nf 1 3 4\n");
  for (const char* method : {"pathtrace", "progressive", "matrix"}) {
    SCOPED_TRACE(method);
    const auto r = runCli("render " + obj + " --method " + method +
                          " --environment 1,1,1 --work-plane 0.5 --width 8 --height 8 -o " +
                          dir.file("x.png"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const size_t at = r.output.find("E_avg ");
    ASSERT_NE(at, std::string::npos) << r.output;
    EXPECT_NEAR(std::stod(r.output.substr(at + 6)), M_PI * 683.0, 0.5) << r.output;
  }
}

TEST(Cli, InfoDescribesTheBuiltInCornellBox) {
  const auto r = runCli("info cornell");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("triangles  36"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("emission (17, 12, 4)"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace penumbra
