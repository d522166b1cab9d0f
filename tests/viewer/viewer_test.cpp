// The interactive viewer for real: penumbra view under Xvfb (Mesa's GLX), driven by a scripted
// light path, its window captured. The captures change as the light moves, and each matches a
// headless `penumbra render` of the same state, on either device; dropped files open or show
// their error; bad input is refused before a window opens.
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

const glm::vec3 kFrom(0.12f, 0.45f, 0.2f), kTo(0.44f, 0.45f, 0.35f);
const glm::vec3 kBunnyFrom(-0.05f, 0.25f, -0.35f), kBunnyTo(0.2f, 0.25f, -0.3f);

// A light moving in the viewer and the same states rendered headless.
struct Relight {
  std::string method, options;  // the options both commands take
  bool bunny = false;           // the marble bunny, else the box
  glm::vec3 from, to;
  std::string device = "cpu";
};
struct Relit {
  std::string first, last;  // the viewer's captures with the light at `from`, `to`
  std::string headless_first, headless_last;  // `penumbra render` of the same states
  nlohmann::json stats;                       // the viewer's
};

Relit relight(TempDir& dir, const std::string& display, const Relight& c) {
  const std::string name = c.method + "_" + c.device;
  auto scene = [&](const std::string& file, const glm::vec3& light) {
    return c.bunny ? bunnyScene(dir, file, light) : boxScene(dir, file, light);
  };
  const std::string start = scene(name + "_start.json", c.from);
  const std::string end = scene(name + "_end.json", c.to);
  const std::string script = dir.write(
      name + "_script.json", fmt::format(R"({{"light_path": [[{}, {}, {}], [{}, {}, {}]]}})",
                                         c.from.x, c.from.y, c.from.z, c.to.x, c.to.y, c.to.z));
  const std::string size = " --width 64 --height 64 --device " + c.device + " ";
  const auto v = runCli(fmt::format("view {} --method {} {}{}--hide-ui --script {} --frames 2 "
                                    "--sequence --screenshot {} --stats {}",
                                    start, c.method, c.options, size, script,
                                    dir.file(name + ".png"), dir.file(name + ".json")),
                        "DISPLAY=" + display);
  EXPECT_EQ(v.exit_code, 0) << v.output;
  Relit r{dir.file(name + "_0000.png"),
          dir.file(name + "_0001.png"),
          dir.file(name + "_cli_start.png"),
          dir.file(name + "_cli_end.png"),
          {}};
  for (const auto& [in, out] : {std::pair{start, r.headless_first}, {end, r.headless_last}}) {
    const auto h = runCli(
        fmt::format("render {} --method {} {}{}--quiet -o {}", in, c.method, c.options, size, out));
    EXPECT_EQ(h.exit_code, 0) << h.output;
  }
  if (v.exit_code == 0) r.stats = test::readJson(dir.file(name + ".json"));
  return r;
}

// Every method on the CPU: the light moved, the capture changed, and each capture is the
// headless render of its state: to the byte for the path tracer (a finished preview is
// render()'s image), progressive and stochastic radiosity (built again and solved for the moved
// light) and the light propagation volumes (a frame for the light where it is); matrix radiosity
// relit in the window (the form factors kept, the solve continued from the last light's
// solution) to the solve's tolerance.
TEST(Viewer, EveryMethodsCaptureIsItsHeadlessRender) {
  PENUMBRA_DISPLAY_OR_SKIP(display);
  TempDir dir;
  const struct {
    Relight relight;
    double moved, bar;
  } cases[] = {
      {{"pathtrace", "--spp 4 --seed 3", false, kFrom, kTo}, 0.1, 0.0},
      {{"matrix", "--elements 400 --spp 1", false, kFrom, kTo}, 0.1, 0.01},
      {{"progressive", "--elements 3000 --iterations 60 --spp 1", false, kFrom, kTo}, 0.05, 0.0},
      {{"stochastic", "--elements 3000 --iterations 40 --spp 1", false, kFrom, kTo}, 0.05, 0.0},
      {{"lpv", "--spp 1", true, kBunnyFrom, kBunnyTo}, 0.05, 0.0},
  };
  for (const auto& c : cases) {
    const Relit r = relight(dir, display, c.relight);
    const double moved = difference(r.first, r.last);
    const double first = difference(r.first, r.headless_first);
    const double last = difference(r.last, r.headless_last);
    std::printf("%s: the capture changed by %.3f as the light moved; vs headless %.2e, %.2e\n",
                c.relight.method.c_str(), moved, first, last);
    EXPECT_GT(moved, c.moved) << c.relight.method;
    // The first frame is a fresh solve of the scene's own camera and light: the headless render.
    EXPECT_EQ(first, 0.0) << c.relight.method;
    if (c.bar == 0.0) {
      EXPECT_EQ(last, 0.0) << c.relight.method;
    } else {
      EXPECT_LT(last, c.bar) << c.relight.method;
    }
  }
}

// The textured room as Blender's exporter writes it (base colour and emissive textures, a MASK
// lattice): the window shows what `render` computes, textures and cut-outs included, to the
// byte for the path tracer and progressive radiosity.
TEST(Viewer, TexturedRoomCaptureIsItsHeadlessRender) {
  PENUMBRA_DISPLAY_OR_SKIP(display);
  TempDir dir;
  const std::string room = std::string(PENUMBRA_SOURCE_DIR) + "/scenes/textured_room/room.glb";
  for (const std::string options :
       {"--method pathtrace --spp 4", "--method progressive --elements 3000 --spp 1"}) {
    const std::string size = " --width 48 --height 32 ";
    const auto v = runCli(fmt::format("view {} {}{}--hide-ui --frames 1 --screenshot {}", room,
                                      options, size, dir.file("view.png")),
                          "DISPLAY=" + display);
    ASSERT_EQ(v.exit_code, 0) << v.output;
    const auto h = runCli(
        fmt::format("render {} {}{}--quiet -o {}", room, options, size, dir.file("render.png")));
    ASSERT_EQ(h.exit_code, 0) << h.output;
    const double d = difference(dir.file("view.png"), dir.file("render.png"));
    std::printf("textured room, %s: the capture vs render %.2e\n", options.c_str(), d);
    EXPECT_EQ(d, 0.0) << options;
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
    Relight relight;
    double bar;
  } cases[] = {
      {{"matrix", "--elements 400 --spp 1", false, kFrom, kTo, "gpu"}, 0.01},
      {{"lpv", "--spp 1", true, kBunnyFrom, kBunnyTo, "gpu"}, 0.0},
  };
  for (const auto& c : cases) {
    const Relit r = relight(dir, display, c.relight);
    EXPECT_EQ(r.stats["device"], "gpu");
    const double d = difference(r.last, r.headless_last);
    std::printf("%s on the GPU: the relit capture vs render --device gpu %.2e\n",
                c.relight.method.c_str(), d);
    EXPECT_LE(d, c.bar) << c.relight.method;
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
      // Checked before the window opens, not after its frames.
      {"view cornell --screenshot /proc/none/a.png", "/proc/none"},
      {"view cornell --screenshot " + dir.file("a.png") + " --stats /proc/s.json", "/proc"},
      {"view cornell --budget-ms nan", "--budget-ms"},
      {"view cornell --exposure inf", "--exposure"},
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
