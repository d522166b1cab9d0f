// The public API (penumbra.h) from C++: results equal the library's own, errors carry their kind
// and the library's message, progress reaches the end, and requestInterrupt() stops a render
// from another thread (the Python module's Ctrl-C goes through the same call).
#include "penumbra/penumbra.h"

#include "support/test_util.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <atomic>
#include <chrono>
#include <cmath>
#include <thread>

namespace penumbra {
namespace {

TEST(Api, RenderGivesTheImageAndStatsAndWritesNothingUnasked) {
  test::TempDir dir;
  const api::Scene scene = api::Scene::load("cornell");
  EXPECT_EQ(scene.triangleCount(), 36u);
  const api::Result a = api::render(scene, {"--spp", "4", "--width", "20", "--height", "10"});
  ASSERT_EQ(a.images.size(), 1u);
  EXPECT_EQ(a.images[0].width, 20);
  EXPECT_EQ(a.images[0].height, 10);
  ASSERT_EQ(a.images[0].rgb.size(), 20u * 10u * 3u);
  for (float v : a.images[0].rgb) ASSERT_TRUE(std::isfinite(v) && v >= 0.0f);
  const nlohmann::json stats = nlohmann::json::parse(a.stats_json);
  EXPECT_EQ(stats["spp"], 4);
  EXPECT_FALSE(a.interrupted);
  // The same options on one thread: the same floats (the image does not depend on threads).
  const api::Result b =
      api::render(scene, {"--spp", "4", "--width", "20", "--height", "10", "--threads", "1"});
  EXPECT_EQ(a.images[0].rgb, b.images[0].rgb);
  // Written only where -o says; read back, the same values.
  const std::string exr = (dir.path() / "a.exr").string();
  (void)api::render(scene, {"--spp", "4", "--width", "20", "--height", "10", "-o", exr});
  EXPECT_EQ(api::readImage(exr).rgb, a.images[0].rgb);
}

// Typed options give the string form's result, and are checked by the same descriptions: a value
// of the wrong kind, out of the method's range or of another method is refused by name.
TEST(Api, TypedOptionsAreTheStringFormsAndCheckedTheSameWay) {
  const api::Scene scene = api::Scene::load("cornell");
  const api::Result words =
      api::render(scene, {"--method", "matrix", "--elements", "400", "--width", "24", "--height",
                          "16", "--tonemap", "exposure"});
  const api::Result typed = api::render(scene, api::Options{{"method", "matrix"},
                                                            {"elements", 400},
                                                            {"width", 24},
                                                            {"height", 16},
                                                            {"tonemap", "exposure"}});
  ASSERT_EQ(words.images.size(), 1u);
  ASSERT_EQ(typed.images.size(), 1u);
  EXPECT_EQ(words.images[0].rgb, typed.images[0].rgb);
  const auto refused = [&](const api::Options& options, const std::string& part) {
    try {
      (void)api::render(scene, options);
      ADD_FAILURE() << part << ": no error";
    } catch (const api::Error& e) {
      EXPECT_EQ(e.kind(), api::ErrorKind::kInput);
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  refused({{"spp", "64"}}, "spp: must be an integer");
  refused({{"spp", 0}}, "spp: 0 is out of range");
  refused({{"width", 2.5}}, "width: must be an integer");
  refused({{"light_samples", 2}}, "applies to --method whitted and photons only");
  refused({{"max-depth", true}}, "max-depth: must be an integer");
  refused({{"elements", -1}, {"method", "matrix"}}, "elements");

  // The descriptions themselves, for bindings.
  const std::vector<api::MethodDescription> methods = api::methods();
  EXPECT_EQ(methods.size(), 8u);
  bool spp = false;
  for (const api::OptionDescription& o : api::options("render")) {
    if (o.name != "spp") continue;
    spp = true;
    EXPECT_EQ(o.kind, "int");
    ASSERT_FALSE(o.methods.empty());
    EXPECT_EQ(o.range, "[1, 4096]");
    EXPECT_EQ(o.methods[0].method, "pathtrace");
    EXPECT_EQ(o.methods[0].default_value, "64");
    EXPECT_EQ(o.methods[0].range, "[1, 1048576]");
  }
  EXPECT_TRUE(spp);
}

TEST(Api, ErrorsCarryTheirKindAndTheLibrarysMessage) {
  try {
    (void)api::Scene::load("/no/such/scene.obj");
    FAIL() << "no error";
  } catch (const api::Error& e) {
    EXPECT_EQ(e.kind(), api::ErrorKind::kInput);
    EXPECT_EQ(e.exitCode(), 2);
    EXPECT_NE(std::string(e.what()).find("/no/such/scene.obj"), std::string::npos) << e.what();
  }
  const api::Scene scene = api::Scene::load("cornell");
  try {
    (void)api::render(scene, {"--spp", "0"});
    FAIL() << "no error";
  } catch (const api::Error& e) {
    EXPECT_EQ(e.kind(), api::ErrorKind::kInput);
    EXPECT_NE(std::string(e.what()).find("--spp"), std::string::npos) << e.what();
  }
  const float nan = std::nanf("");
  const std::vector<float> positions = {0, 0, 0, 1, 0, 0, 0, nan, 0};
  const std::vector<uint32_t> indices = {0, 1, 2};
  try {
    (void)api::Scene::fromArrays(positions, indices, {}, "", "mine");
    FAIL() << "no error";
  } catch (const api::Error& e) {
    EXPECT_EQ(e.kind(), api::ErrorKind::kInput);
    EXPECT_NE(std::string(e.what()).find("mine: mesh 0"), std::string::npos) << e.what();
  }
}

TEST(Api, ProgressReachesTheEnd) {
  const api::Scene scene = api::Scene::load("cornell");
  std::atomic<int> calls{0};
  std::atomic<double> last{-1.0};
  (void)api::render(scene, {"--spp", "2", "--width", "32", "--height", "32"},
                    [&](const std::string& stage, double fraction) {
                      EXPECT_EQ(stage, "rendering");
                      EXPECT_GE(fraction, 0.0);
                      EXPECT_LE(fraction, 1.0);
                      ++calls;
                      last = fraction;
                    });
  EXPECT_GE(calls.load(), 2);
  EXPECT_EQ(last.load(), 1.0);
}

TEST(Api, RequestInterruptStopsARenderWithAnError) {
  const api::Scene scene = api::Scene::load("cornell");
  std::atomic<bool> started{false};
  std::thread stopper([&] {
    while (!started) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    api::requestInterrupt();
  });
  const auto t0 = std::chrono::steady_clock::now();
  try {
    (void)api::render(scene, {"--spp", "100000", "--width", "128", "--height", "128"},
                      [&](const std::string&, double) { started = true; });
    ADD_FAILURE() << "the render was not interrupted";
  } catch (const api::Error& e) {
    EXPECT_EQ(e.kind(), api::ErrorKind::kInterrupted);
    EXPECT_EQ(e.exitCode(), 130);
  }
  stopper.join();
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 20.0);
  // The request is forgotten when the next call starts.
  const api::Result next = api::render(scene, {"--spp", "1", "--width", "8", "--height", "8"});
  EXPECT_EQ(next.images.size(), 1u);
}

TEST(Api, TraceAnswersAsGeometrySays) {
  // The unit square z = 0 from arrays; rays straight down from z = 2.
  const std::vector<float> positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
  const std::vector<uint32_t> indices = {0, 1, 2, 0, 2, 3};
  const api::Scene square = api::Scene::fromArrays(positions, indices, {}, "");
  const float inf = INFINITY;
  const std::vector<float> rays = {0.25f, 0.5f, 2, 0, 0, 0, -1, inf,   // inside
                                   1.5f,  0.5f, 2, 0, 0, 0, -1, inf};  // outside
  api::TraceOptions options;
  options.device = "cpu";
  const api::Hits hits = api::trace(square, rays, options);
  ASSERT_EQ(hits.triangle.size(), 2u);
  EXPECT_GE(hits.triangle[0], 0);
  EXPECT_FLOAT_EQ(hits.t[0], 2.0f);
  EXPECT_EQ(hits.triangle[1], -1);
  EXPECT_TRUE(std::isinf(hits.t[1]));
  options.occlusion = true;
  const api::Hits occluded = api::trace(square, rays, options);
  EXPECT_EQ(occluded.occluded, (std::vector<uint8_t>{1, 0}));
}

}  // namespace
}  // namespace penumbra
