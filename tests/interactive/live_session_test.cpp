// Live sessions followed through many changes: after a light has moved again and again, the
// session's image is a fresh session's of the final state. Matrix radiosity relit more times
// than its iteration cap still solves each relighting (the cap counts per solve), to the solve's
// tolerance; the path tracer, its lights swapped without a new BVH, gives the same image bit
// for bit.
#include "penumbra/interactive/live_session.h"
#include "penumbra/interactive/live_settings.h"
#include "penumbra/io/scene_io.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

namespace penumbra {
namespace {

Scene litCornell(const glm::vec3& light) {
  Expected<Scene> s = loadScene("cornell");
  EXPECT_TRUE(s.ok());
  s->lights.push_back(PointLight{light, glm::vec3(0.3f)});
  return std::move(*s);
}

glm::vec3 lightAt(int k) {
  return glm::vec3(0.1f + 0.07f * float(k), 0.45f, 0.15f + 0.04f * float(k));
}

Image finished(LiveSession& s) {
  Expected<LiveStep> step = s.advance(0.0);
  EXPECT_TRUE(step.ok()) << step.error().describe();
  EXPECT_TRUE(s.done());
  return s.image();
}

double relativeRms(const Image& a, const Image& b) {
  double d = 0.0, n = 0.0;
  for (size_t i = 0; i < a.pixels.size(); ++i) {
    const glm::vec3 e = a.pixels[i] - b.pixels[i];
    d += double(glm::dot(e, e));
    n += double(glm::dot(b.pixels[i], b.pixels[i]));
  }
  return std::sqrt(d / n);
}

TEST(LiveSession, MatrixRelitPastItsIterationCapStillSolves) {
  LiveSettings settings;
  settings.width = settings.height = 40;
  settings.spp = 1;
  settings.elements = 300;
  settings.iterations = 12;  // fewer than the relightings below take in all
  const Scene start = litCornell(lightAt(0));
  Expected<LiveSession> live =
      LiveSession::create(start, LiveMethod::kMatrix, settings, *start.camera);
  ASSERT_TRUE(live.ok());
  finished(*live);
  for (int k = 1; k <= 6; ++k) {
    live->setLights(litCornell(lightAt(k)).lights);
    finished(*live);
  }
  const Scene end = litCornell(lightAt(6));
  Expected<LiveSession> fresh =
      LiveSession::create(end, LiveMethod::kMatrix, settings, *end.camera);
  ASSERT_TRUE(fresh.ok());
  const Image want = finished(*fresh);
  const double rms = relativeRms(live->image(), want);
  std::printf("matrix relit 6 times (cap 12 iterations a solve): %s; vs a fresh solve %.2e\n",
              live->status().c_str(), rms);
  EXPECT_LT(rms, 1e-3);
}

TEST(LiveSession, PathTracerWithMovedLightsIsAFreshRender) {
  LiveSettings settings;
  settings.width = settings.height = 24;
  settings.spp = 3;
  const Scene start = litCornell(lightAt(0));
  Expected<LiveSession> live =
      LiveSession::create(start, LiveMethod::kPathTrace, settings, *start.camera);
  ASSERT_TRUE(live.ok());
  const Image first = finished(*live);
  live->setLights(litCornell(lightAt(5)).lights);
  const Image moved = finished(*live);
  const Scene end = litCornell(lightAt(5));
  Expected<LiveSession> fresh =
      LiveSession::create(end, LiveMethod::kPathTrace, settings, *end.camera);
  ASSERT_TRUE(fresh.ok());
  const Image want = finished(*fresh);
  EXPECT_GT(relativeRms(first, want), 0.05);  // the light did move
  EXPECT_EQ(
      std::memcmp(moved.pixels.data(), want.pixels.data(), want.pixels.size() * sizeof(glm::vec3)),
      0);
}

}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {

std::vector<std::string> names(const std::vector<const OptionSpec*>& specs) {
  std::vector<std::string> out;
  for (const OptionSpec* s : specs) out.push_back(s->name);
  return out;
}

// A live session's options come from `render`'s descriptions: the same set per method, the same
// defaults and ranges, and the scene's settings for what the caller leaves to the method.
TEST(LiveSettings, AreRendersOptionsCheckedByTheirDescriptions) {
  EXPECT_EQ(names(liveOptionSpecs(LiveMethod::kPathTrace)),
            (std::vector<std::string>{"spp", "seed"}));
  EXPECT_EQ(names(liveOptionSpecs(LiveMethod::kMatrix)),
            (std::vector<std::string>{"spp", "seed", "elements", "iterations"}));
  const std::vector<std::string> lpv = names(liveOptionSpecs(LiveMethod::kLpv));
  EXPECT_NE(std::find(lpv.begin(), lpv.end(), "grid"), lpv.end());
  EXPECT_EQ(std::find(lpv.begin(), lpv.end(), "elements"), lpv.end());

  LiveSettings settings;
  const OptionSpec& spp = *liveOptionSpecs(LiveMethod::kPathTrace)[0];
  EXPECT_EQ(std::get<int64_t>(liveOptionValue(settings, LiveMethod::kPathTrace, spp)), 64);
  EXPECT_EQ(std::get<int64_t>(liveOptionValue(settings, LiveMethod::kMatrix, spp)), 4);
  // The path tracer's own range, not the others'.
  EXPECT_TRUE(setLiveOption(settings, LiveMethod::kPathTrace, spp, OptionValue(int64_t(65536))));
  EXPECT_EQ(settings.spp, 65536);
  const Status refused =
      setLiveOption(settings, LiveMethod::kMatrix, spp, OptionValue(int64_t(65536)));
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().describe().find("--spp"), std::string::npos)
      << refused.error().describe();

  // The scene's settings fill what the caller left; the caller's values win.
  Scene scene = litCornell(lightAt(0));
  scene.settings = {{"matrix", {{"elements", 300}, {"iterations", 7}, {"spp", 2}}}};
  LiveSettings mine;
  mine.elements = 500;
  Expected<LiveSettings> resolved = resolveLiveSettings(scene, LiveMethod::kMatrix, mine);
  ASSERT_TRUE(resolved.ok()) << resolved.error().describe();
  EXPECT_EQ(resolved->elements, 500u);
  EXPECT_EQ(resolved->iterations, 7);
  EXPECT_EQ(resolved->spp, 2);
  scene.settings = {{"matrix", {{"iterations", 0}}}};
  Expected<LiveSession> bad =
      LiveSession::create(scene, LiveMethod::kMatrix, LiveSettings{}, defaultCamera(scene));
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().describe().find("settings.matrix.iterations"), std::string::npos)
      << bad.error().describe();
}

}  // namespace
}  // namespace penumbra
