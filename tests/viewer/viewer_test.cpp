// The interactive viewer for real: penumbra view under Xvfb (Mesa's GLX), driven by a scripted
// light path, its window captured. The captures change as the light moves, and each matches a
// headless `penumbra render` of the same state: the path tracer's to the byte (a finished
// preview is render()'s image), matrix radiosity relit by the viewer (the form factors kept,
// the solve continued from the last light's solution) to the solver's tolerance.
#include "penumbra/io/image_io.h"
#include "support/test_util.h"
#include "support/x_display.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

namespace penumbra {
namespace {

using test::runCli;
using test::TempDir;

// The Cornell box's walls and blocks (no luminaire) lit by one point light at `light`.
std::string boxScene(TempDir& dir, const std::string& name, const glm::vec3& light) {
  std::string meshes;
  const std::pair<const char*, const char*> parts[] = {
      {"floor", "white"}, {"ceiling", "white"},  {"back", "white"},    {"greenwall", "green"},
      {"redwall", "red"}, {"smallbox", "white"}, {"largebox", "white"}};
  for (const auto& [file, material] : parts) {
    meshes += fmt::format(
        R"({}{{"file": "{}/scenes/cornell/{}.obj", "material": "{}", "transform": {{"scale": 0.001}}}})",
        meshes.empty() ? "" : ",\n    ", PENUMBRA_SOURCE_DIR, file, material);
  }
  return dir.write(name, fmt::format(R"({{
  "materials": {{
    "white": {{"reflectance": [0.725, 0.71, 0.68]}},
    "red": {{"reflectance": [0.63, 0.065, 0.05]}},
    "green": {{"reflectance": [0.14, 0.45, 0.091]}}
  }},
  "meshes": [
    {}
  ],
  "lights": [{{"type": "point", "position": [{}, {}, {}], "intensity": [0.5, 0.5, 0.5]}}],
  "camera": {{"position": [0.278, 0.273, -0.8], "look_at": [0.278, 0.273, 0.0], "fov_deg": 39.3}}
}})",
                                     meshes, light.x, light.y, light.z));
}

// Relative RMS difference of two images (linear, as read back).
double difference(const std::string& a, const std::string& b) {
  Expected<Image> x = readImage(a), y = readImage(b);
  EXPECT_TRUE(x.ok()) << a;
  EXPECT_TRUE(y.ok()) << b;
  if (!x.ok() || !y.ok() || x->pixels.size() != y->pixels.size()) return 1e9;
  double d = 0.0, s = 0.0;
  for (size_t i = 0; i < x->pixels.size(); ++i) {
    const glm::vec3 e = x->pixels[i] - y->pixels[i];
    d += double(glm::dot(e, e));
    s += double(glm::dot(y->pixels[i], y->pixels[i]));
  }
  return std::sqrt(d / s);
}

struct Capture {
  std::string first, last;  // the first and the last frame's captures
};

// The viewer with the light moving from `from` to `to` over three frames; every frame captured.
Capture runViewer(TempDir& dir, const std::string& display, const std::string& method,
                  const std::string& options, const glm::vec3& from, const glm::vec3& to) {
  const std::string scene = boxScene(dir, method + "_start.json", from);
  const std::string script =
      dir.write(method + "_script.json",
                fmt::format(R"({{"light": 0, "light_path": [[{}, {}, {}], [{}, {}, {}]]}})", from.x,
                            from.y, from.z, to.x, to.y, to.z));
  const std::string shot = dir.file(method + ".png");
  const auto r = runCli(fmt::format("view {} --method {} {} --width 64 --height 64 --hide-ui "
                                    "--script {} --frames 3 --sequence --screenshot {}",
                                    scene, method, options, script, shot),
                        "DISPLAY=" + display);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  return {dir.file(method + "_0000.png"), dir.file(method + "_0002.png")};
}

// The same state rendered headless.
std::string renderHeadless(TempDir& dir, const std::string& method, const std::string& options,
                           const glm::vec3& light, const std::string& name) {
  const std::string scene = boxScene(dir, name + ".json", light);
  const std::string out = dir.file(name + ".png");
  const auto r = runCli(fmt::format("render {} --method {} {} --width 64 --height 64 --quiet -o {}",
                                    scene, method, options, out));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  return out;
}

const glm::vec3 kFrom(0.12f, 0.45f, 0.2f), kTo(0.44f, 0.45f, 0.35f);

TEST(Viewer, PathTracerCapturesAreTheHeadlessRenders) {
  PENUMBRA_DISPLAY_OR_SKIP(display);
  TempDir dir;
  const std::string options = "--spp 4 --seed 3";
  const Capture c = runViewer(dir, display, "pathtrace", options, kFrom, kTo);
  const std::string start = renderHeadless(dir, "pathtrace", options, kFrom, "pt_start");
  const std::string end = renderHeadless(dir, "pathtrace", options, kTo, "pt_end");
  const double moved = difference(c.first, c.last);
  const double first = difference(c.first, start), last = difference(c.last, end);
  std::printf(
      "path tracer: the light moved, the capture changed by %.3f; captures vs headless "
      "renders %.2e and %.2e\n",
      moved, first, last);
  EXPECT_GT(moved, 0.1);
  EXPECT_EQ(first, 0.0);
  EXPECT_EQ(last, 0.0);
}

TEST(Viewer, MatrixRelightingFollowsTheLight) {
  PENUMBRA_DISPLAY_OR_SKIP(display);
  TempDir dir;
  const std::string options = "--elements 400 --spp 1";
  const Capture c = runViewer(dir, display, "matrix", options, kFrom, kTo);
  const std::string end = renderHeadless(dir, "matrix", options, kTo, "matrix_end");
  const double moved = difference(c.first, c.last), last = difference(c.last, end);
  std::printf(
      "matrix radiosity: the capture changed by %.3f as the light moved; relit capture "
      "vs headless render %.2e\n",
      moved, last);
  EXPECT_GT(moved, 0.1);
  EXPECT_LT(last, 0.01);
}

// The bunny in marble lit by one point light at `light`, seen as the built-in `lpv` scene.
std::string bunnyScene(TempDir& dir, const std::string& name, const glm::vec3& light) {
  return dir.write(name, fmt::format(R"({{
  "materials": {{"marble": {{"subsurface": {{"preset": "marble"}}}}}},
  "meshes": [{{"file": "{}/bunny.ply", "material": "marble"}}],
  "lights": [{{"type": "point", "position": [{}, {}, {}], "intensity": [0.8, 0.8, 0.8]}}],
  "camera": {{"position": [-0.017, 0.115, 0.42], "look_at": [-0.017, 0.11, 0.0], "fov_deg": 25.8}}
}})",
                                     PENUMBRA_TEST_DATA, light.x, light.y, light.z));
}

// Progressive and stochastic radiosity (built again and solved for the moved light) and the
// light propagation volumes (a frame for the light where it is): each capture is the headless
// render of the same state to the byte.
TEST(Viewer, EveryMethodsCaptureIsItsHeadlessRender) {
  PENUMBRA_DISPLAY_OR_SKIP(display);
  TempDir dir;
  const struct {
    const char* method;
    std::string options;
    bool bunny;
    glm::vec3 from, to;
  } cases[] = {
      {"progressive", "--elements 3000 --iterations 60 --spp 1", false, kFrom, kTo},
      {"stochastic", "--elements 3000 --iterations 40 --spp 1", false, kFrom, kTo},
      {"lpv", "--spp 1", true, glm::vec3(-0.05f, 0.25f, -0.35f), glm::vec3(0.2f, 0.25f, -0.3f)},
  };
  for (const auto& c : cases) {
    const std::string method = c.method;
    const std::string start = c.bunny ? bunnyScene(dir, method + "_start.json", c.from)
                                      : boxScene(dir, method + "_start.json", c.from);
    const std::string end = c.bunny ? bunnyScene(dir, method + "_end.json", c.to)
                                    : boxScene(dir, method + "_end.json", c.to);
    const std::string script = dir.write(
        method + "_script.json", fmt::format(R"({{"light_path": [[{}, {}, {}], [{}, {}, {}]]}})",
                                             c.from.x, c.from.y, c.from.z, c.to.x, c.to.y, c.to.z));
    const auto v = runCli(fmt::format("view {} --method {} {} --width 64 --height 64 --hide-ui "
                                      "--script {} --frames 2 --sequence --screenshot {}",
                                      start, method, c.options, script, dir.file(method + ".png")),
                          "DISPLAY=" + display);
    ASSERT_EQ(v.exit_code, 0) << v.output;
    const auto h =
        runCli(fmt::format("render {} --method {} {} --width 64 --height 64 --quiet -o {}", end,
                           method, c.options, dir.file(method + "_cli.png")));
    ASSERT_EQ(h.exit_code, 0) << h.output;
    const double moved = difference(dir.file(method + "_0000.png"), dir.file(method + "_0001.png"));
    const double last = difference(dir.file(method + "_0001.png"), dir.file(method + "_cli.png"));
    std::printf("%s: the capture changed by %.3f as the light moved; vs headless %.2e\n", c.method,
                moved, last);
    EXPECT_GT(moved, 0.05) << c.method;
    EXPECT_EQ(last, 0.0) << c.method;
  }
}

// --device gpu: the GPU twins in the window's own context (GLX here) give what `render --device
// gpu` gives headless (EGL): matrix radiosity's Jacobi solve, relit, to the solver's tolerance,
// and the light propagation volumes to the byte.
TEST(Viewer, GpuTwinsCaptureAsRenderDoesOnTheGpu) {
  PENUMBRA_GL_OR_SKIP();
  PENUMBRA_DISPLAY_OR_SKIP(display);
  TempDir dir;
  const struct {
    const char* method;
    std::string options;
    bool bunny;
    glm::vec3 from, to;
    double bar;
  } cases[] = {
      {"matrix", "--elements 400 --spp 1", false, kFrom, kTo, 0.01},
      {"lpv", "--spp 1", true, glm::vec3(-0.05f, 0.25f, -0.35f), glm::vec3(0.2f, 0.25f, -0.3f),
       0.0},
  };
  for (const auto& c : cases) {
    const std::string method = c.method;
    const std::string start = c.bunny ? bunnyScene(dir, method + "_start.json", c.from)
                                      : boxScene(dir, method + "_start.json", c.from);
    const std::string end = c.bunny ? bunnyScene(dir, method + "_end.json", c.to)
                                    : boxScene(dir, method + "_end.json", c.to);
    const std::string script = dir.write(
        method + "_script.json", fmt::format(R"({{"light_path": [[{}, {}, {}], [{}, {}, {}]]}})",
                                             c.from.x, c.from.y, c.from.z, c.to.x, c.to.y, c.to.z));
    const auto v =
        runCli(fmt::format("view {} --method {} {} --device gpu --width 64 --height 64 --hide-ui "
                           "--script {} --frames 2 --screenshot {} --stats {}",
                           start, method, c.options, script, dir.file(method + ".png"),
                           dir.file(method + ".json")),
               "DISPLAY=" + display);
    ASSERT_EQ(v.exit_code, 0) << v.output;
    EXPECT_EQ(test::readJson(dir.file(method + ".json"))["device"], "gpu");
    const auto h = runCli(
        fmt::format("render {} --method {} {} --device gpu --width 64 --height 64 --quiet -o {}",
                    end, method, c.options, dir.file(method + "_cli.png")));
    ASSERT_EQ(h.exit_code, 0) << h.output;
    const double d = difference(dir.file(method + ".png"), dir.file(method + "_cli.png"));
    std::printf("%s on the GPU: the relit capture vs render --device gpu %.2e\n", c.method, d);
    EXPECT_LE(d, c.bar) << c.method;
  }
}

// A dropped file opens (the next frame shows it); one that does not load leaves its error in the
// window (and the stats) and the last scene on screen: never a crash.
TEST(Viewer, DroppedFilesOpenOrShowTheirError) {
  PENUMBRA_DISPLAY_OR_SKIP(display);
  TempDir dir;
  const std::string box = boxScene(dir, "box.json", kFrom);
  for (const auto& [file, error] :
       {std::pair<std::string, std::string>{dir.file("nothing.obj"), "nothing.obj"}, {box, ""}}) {
    const std::string script =
        dir.write("drop.json", fmt::format(R"({{"drop": {{"frame": 1, "file": "{}"}}}})", file));
    const auto r = runCli(fmt::format("view cornell --spp 1 --width 48 --height 48 --frames 3 "
                                      "--script {} --screenshot {} --stats {}",
                                      script, dir.file("d.png"), dir.file("d.json")),
                          "DISPLAY=" + display);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const nlohmann::json stats = test::readJson(dir.file("d.json"));
    const std::string shown = stats["error"].get<std::string>();
    std::printf("dropped %s: error shown \"%s\", scene %s\n", file.c_str(), shown.c_str(),
                stats["scene"].get<std::string>().c_str());
    if (error.empty()) {
      EXPECT_EQ(shown, "");
      EXPECT_EQ(stats["scene"], box);
    } else {
      EXPECT_NE(shown.find(error), std::string::npos) << shown;
      EXPECT_EQ(stats["scene"], "builtin:cornell");
    }
    EXPECT_TRUE(std::filesystem::exists(dir.file("d.png")));
  }
}

// Bad input is refused before a window opens: one line naming the file or option, exit 2.
TEST(Viewer, BadInputIsRefusedBeforeAWindowOpens) {
  TempDir dir;
  const std::string bad_script = dir.write("s.json", R"({"light_path": [[0, 0]]})");
  const struct {
    std::string args, expect;
  } cases[] = {
      {"view " + dir.file("missing.json"), "missing.json"},
      {"view cornell --method lpv", "no translucent material"},
      {"view cornell --method warp", "--method"},
      {"view cornell --frames 3", "--screenshot"},
      {"view cornell --script " + bad_script + " --screenshot " + dir.file("a.png"),
       "light_path[0]"},
      {"view cornell --screenshot " + dir.file("a.exr"), "a.exr"},
  };
  for (const auto& c : cases) {
    const auto r = runCli(c.args, "DISPLAY=");
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.expect), std::string::npos) << c.args << "\n" << r.output;
    EXPECT_FALSE(std::filesystem::exists(dir.file("a.png")));
  }
}

}  // namespace
}  // namespace penumbra
