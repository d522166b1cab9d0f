// The methods' runs as library calls (methods/render.h), not through the command line: results in
// memory that equal the files, a stop request that checkpoints the iterative methods (and the
// checkpoint resumes to exactly the uninterrupted result) and ends the others with nothing
// written, every method's plan refused against the caller's memory budget before it allocates,
// and the scene's settings under the caller's options.
#include "penumbra/core/interrupt.h"
#include "penumbra/io/image_io.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/methods/option_input.h"
#include "penumbra/methods/registry.h"
#include "penumbra/methods/render.h"

#include "support/test_util.h"

#include <gtest/gtest.h>

#include <csignal>
#include <cstring>
#include <filesystem>
#include <memory>

namespace penumbra {
namespace {

using test::TempDir;

std::shared_ptr<const Scene> load(const std::string& name) {
  Expected<Scene> scene = loadScene(name);
  EXPECT_TRUE(scene.ok()) << (scene ? "" : scene.error().describe());
  return std::make_shared<const Scene>(std::move(*scene));
}

// `render` on `scene_name` with the command line's words, as a program calls it.
Expected<RunResult> render(const std::string& scene_name, const std::vector<std::string>& words,
                           RunContext context = {}) {
  RenderOptions defaults;
  defaults.scene = scene_name;
  Expected<RenderInput> input = renderInputFromWords(words, defaults);
  if (!input) return input.error();
  input->common.quiet = true;
  if (!context.scene) context.scene = load(scene_name);
  context.given = input->given;
  return renderScene(input->options, input->common, context);
}

bool sameImage(const Image& a, const Image& b) {
  return a.width == b.width && a.height == b.height &&
         std::memcmp(a.pixels.data(), b.pixels.data(), a.pixels.size() * sizeof(glm::vec3)) == 0;
}

// Clears a stop request on both ends of a test.
struct StopRequests {
  StopRequests() { clearInterrupt(); }
  ~StopRequests() {
    keepInterruptRequests(false);
    clearInterrupt();
  }
};

TEST(MethodRun, KeptResultsEqualTheFilesWritten) {
  TempDir dir;
  RunContext context;
  context.keep_results = true;
  Expected<RunResult> run =
      render("cornell", {"--spp", "4", "--width", "24", "--height", "16", "-o", dir.file("a.pfm")},
             context);
  ASSERT_TRUE(run.ok()) << run.error().describe();
  ASSERT_EQ(run->images.size(), 1u);
  Expected<Image> file = readImage(dir.file("a.pfm"));
  ASSERT_TRUE(file.ok());
  EXPECT_TRUE(sameImage(run->images[0], *file));
  EXPECT_EQ(run->stats["method"], "pathtrace");
  EXPECT_EQ(run->stats["spp"], 4);
  EXPECT_FALSE(run->interrupted);

  // Kept results name no file of their own: nothing is written when no output is named.
  Expected<RunResult> memory =
      render("cornell", {"--spp", "1", "--width", "8", "--height", "8"}, context);
  ASSERT_TRUE(memory.ok());
  EXPECT_FALSE(std::filesystem::exists("cornell.png"));
}

// Progressive and stochastic radiosity stop cleanly at a request made while they iterate: the
// image and a checkpoint are written, and resuming gives the uninterrupted run's image bit for
// bit.
void checkStopAndResume(const std::vector<std::string>& words, int iterations) {
  StopRequests requests;
  TempDir dir;
  RunContext keep;
  keep.keep_results = true;
  std::vector<std::string> full_words = words;
  full_words.insert(full_words.end(), {"-o", dir.file("full.pfm")});
  Expected<RunResult> full = render("cornell", full_words, keep);
  ASSERT_TRUE(full.ok()) << full.error().describe();
  ASSERT_EQ(full->stats["iterations"], iterations);

  // The request comes from the progress callback once the solver iterates (an InterruptScope is
  // alive there: the work stops cleanly by itself).
  RunContext stopping = keep;
  stopping.stop_on_request = true;
  stopping.progress = [](const std::string&, double fraction) {
    if (fraction > 0.0 && InterruptScope::active()) requestInterrupt(SIGINT);
  };
  std::vector<std::string> cut_words = words;
  cut_words.insert(cut_words.end(),
                   {"-o", dir.file("cut.pfm"), "--checkpoint", dir.file("cut.checkpoint")});
  Expected<RunResult> cut = render("cornell", cut_words, stopping);
  ASSERT_TRUE(cut.ok()) << cut.error().describe();
  EXPECT_TRUE(cut->interrupted);
  const int done = cut->stats["iterations"].get<int>();
  EXPECT_LT(done, iterations);
  EXPECT_TRUE(std::filesystem::exists(dir.file("cut.pfm")));
  ASSERT_TRUE(std::filesystem::exists(dir.file("cut.checkpoint")));
  clearInterrupt();

  std::vector<std::string> resume_words = words;
  resume_words.insert(resume_words.end(),
                      {"--resume", dir.file("cut.checkpoint"), "-o", dir.file("resumed.pfm")});
  Expected<RunResult> resumed = render("cornell", resume_words, keep);
  ASSERT_TRUE(resumed.ok()) << resumed.error().describe();
  EXPECT_FALSE(resumed->interrupted);
  EXPECT_EQ(resumed->stats["resumed_iterations"], done);
  EXPECT_EQ(resumed->stats["iterations"], iterations);
  ASSERT_EQ(resumed->images.size(), 1u);
  EXPECT_TRUE(sameImage(full->images[0], resumed->images[0]));
  // The completed run supersedes the checkpoint it continued.
  EXPECT_FALSE(std::filesystem::exists(dir.file("cut.checkpoint")));
}

TEST(MethodRun, ProgressiveStopsAtARequestAndResumesExactly) {
  checkStopAndResume({"--method", "progressive", "--texel-density", "80", "--tolerance", "1e-9",
                      "--iterations", "30", "--width", "24", "--height", "24", "--spp", "1"},
                     30);
}

TEST(MethodRun, StochasticStopsAtARequestAndResumesExactly) {
  checkStopAndResume({"--method", "stochastic", "--elements", "3000", "--iterations", "4000",
                      "--width", "16", "--height", "16", "--spp", "1"},
                     4000);
}

// The methods without a clean stopping point end at a request with Interrupted thrown, and
// nothing they would have written is left.
TEST(MethodRun, AStopRequestEndsTheOtherMethodsWithNothingWritten) {
  struct Case {
    std::string scene;
    std::vector<std::string> words;
  };
  const std::vector<Case> cases = {
      {"cornell", {"--spp", "16", "--width", "64", "--height", "64"}},
      {"cornell", {"--method", "whitted", "--width", "64", "--height", "64"}},
      {"cornell", {"--method", "photons", "--width", "64", "--height", "64"}},
      {"cornell", {"--method", "matrix", "--elements", "2000", "--width", "64", "--height", "64"}},
      {"sss", {"--method", "sss", "--width", "64", "--height", "64"}},
      {"lpv", {"--method", "lpv", "--width", "64", "--height", "64"}},
  };
  for (const Case& c : cases) {
    StopRequests requests;
    TempDir dir;
    RunContext context;
    context.stop_on_request = true;
    // A request made before the run starts is kept (as the API keeps one made during a call).
    keepInterruptRequests(true);
    requestInterrupt(SIGINT);
    std::vector<std::string> words = c.words;
    words.insert(words.end(), {"-o", dir.file("out.pfm")});
    EXPECT_THROW((void)render(c.scene, words, context), Interrupted) << c.words[1];
    EXPECT_FALSE(std::filesystem::exists(dir.file("out.pfm"))) << c.words[1];
  }
}

// Every method checks the memory its plan needs against the caller's budget before allocating
// it, and says how much it needs.
TEST(MethodRun, EveryMethodRefusesAPlanOverTheCallersBudget) {
  for (const MethodInfo& m : methodInfos()) {
    TempDir dir;
    RunContext context;
    context.memory_budget = 64 << 10;
    const std::string scene = m.name == "sss" ? "sss" : m.name == "lpv" ? "lpv" : "cornell";
    Expected<RunResult> run =
        render(scene, {"--method", m.name, "-o", dir.file("out.pfm")}, context);
    ASSERT_FALSE(run.ok()) << m.name << " ran within a 64 KiB budget";
    EXPECT_EQ(run.error().kind, ErrorKind::kInput) << m.name;
    const std::string message = run.error().describe();
    EXPECT_NE(message.find("needs"), std::string::npos) << m.name << ": " << message;
    EXPECT_NE(message.find("the caller's budget"), std::string::npos) << m.name << ": " << message;
    EXPECT_FALSE(std::filesystem::exists(dir.file("out.pfm"))) << m.name;
  }
}

// The scene's "settings" fill in what the caller left, checked as the caller's values are; the
// caller's own options win.
TEST(MethodRun, SceneSettingsFillWhatTheCallerLeft) {
  Scene box = *load("cornell");
  box.settings = {{"pathtrace", {{"spp", 2}, {"width", 8}, {"height", 4}}}};
  RunContext context;
  context.keep_results = true;
  context.scene = std::make_shared<const Scene>(box);
  Expected<RunResult> run = render("cornell", {"--width", "16"}, context);
  ASSERT_TRUE(run.ok()) << run.error().describe();
  EXPECT_EQ(run->stats["spp"], 2);
  EXPECT_EQ(run->stats["width"], 16);
  EXPECT_EQ(run->stats["height"], 4);

  box.settings = {{"pathtrace", {{"spp", 0}}}};
  context.scene = std::make_shared<const Scene>(box);
  Expected<RunResult> refused = render("cornell", {}, context);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().kind, ErrorKind::kInput);
  EXPECT_NE(refused.error().describe().find("settings.pathtrace.spp"), std::string::npos)
      << refused.error().describe();
}

// A bake takes the scene's settings for its method too: the lightmap's and the solver's.
TEST(MethodRun, BakeTakesTheScenesSettingsForItsMethod) {
  TempDir dir;
  Scene box = *load("cornell");
  box.settings = {{"stochastic", {{"iterations", 12}, {"seed", 3}, {"spp", 2}}}};
  RunContext context;
  context.keep_results = true;
  context.scene = std::make_shared<const Scene>(box);
  BakeOptions defaults;
  defaults.scene = "cornell";
  Expected<BakeInput> input = bakeInputFromWords(
      {"--method", "stochastic", "--elements", "2000", "-o", dir.file("out"), "--quiet"}, defaults);
  ASSERT_TRUE(input.ok()) << input.error().describe();
  context.given = input->given;
  Expected<RunResult> run = bakeScene(input->options, input->common, context);
  ASSERT_TRUE(run.ok()) << run.error().describe();
  EXPECT_EQ(run->stats["iterations"], 12);
  EXPECT_EQ(run->stats["seed"], 3);
  EXPECT_TRUE(std::filesystem::exists(dir.file("out/cornell.gltf")));

  box.settings = {{"stochastic", {{"iterations", -1}}}};
  context.scene = std::make_shared<const Scene>(box);
  Expected<RunResult> refused = bakeScene(input->options, input->common, context);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().describe().find("settings.stochastic.iterations"), std::string::npos)
      << refused.error().describe();
}

}  // namespace
}  // namespace penumbra
