// The textured room as Blender's glTF exporter wrote it (a chequered floor, a painting on a second
// UV set, an emissive screen, a cut-out lattice under the ceiling panel), baked by progressive and
// matrix radiosity with the asset output, against the path-traced bake of the same atlas: the
// irradiance lightmaps agree within 5% RMS over the texels of surface (docs/performance.md,
// "Time to a lightmap error").
#include "penumbra/core/color.h"
#include "penumbra/io/image_io.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/radiosity/radiosity_surface.h"
#include "support/test_util.h"

#include <gtest/gtest.h>

#include <glm/common.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace penumbra {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::runCli;
using test::TempDir;

// Per texel of the atlas, the weight the comparison gives it: the share of it that is surface
// (its element's coverage) where the baked file's lightmap UVs use it (each mesh keeps one side:
// the outsides of the room's walls are not compared) and the irradiance is measured (reflectance
// of at least 0.02; the others, and the gutters, are filled from their neighbours), else 0.
std::vector<double> texelWeights(const Scene& scene, double density, const fs::path& baked) {
  ChartAtlasOptions o;
  o.texel_density = density;
  Expected<RadiositySurface> s = RadiositySurface::build(scene, o, true);
  EXPECT_TRUE(s.ok());
  const int w = s->atlas.width, h = s->atlas.height;
  // The texels the baked file's lightmap triangles overlap (4 x 4 points a texel).
  const json doc = test::readJson(baked.string());
  std::map<std::string, int> sets;
  for (const json& m : doc["materials"]) {
    if (m.contains("extensions") && m["extensions"].contains("PENUMBRA_lightmap")) {
      sets[m.value("name", std::string())] = m["extensions"]["PENUMBRA_lightmap"]["texCoord"];
    }
  }
  Expected<Scene> back = loadScene(baked.string());
  EXPECT_TRUE(back.ok());
  std::vector<uint8_t> used(size_t(w) * size_t(h), 0);
  for (const Mesh& m : back->meshes) {
    for (size_t t = 0; t < m.triangles.size(); ++t) {
      const std::string& name = back->materials[m.material_ids[t]].name;
      if (!sets.count(name)) continue;
      const std::vector<glm::vec2>& uv = m.uvSet(uint32_t(sets.at(name)));
      const glm::uvec3 tri = m.triangles[t];
      const glm::dvec2 a = glm::dvec2(uv[tri.x]) * glm::dvec2(w, h),
                       b = glm::dvec2(uv[tri.y]) * glm::dvec2(w, h),
                       c = glm::dvec2(uv[tri.z]) * glm::dvec2(w, h);
      const double det = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
      if (det == 0.0) continue;
      const glm::dvec2 lo = glm::min(a, glm::min(b, c)), hi = glm::max(a, glm::max(b, c));
      for (int y = std::max(0, int(lo.y)); y < std::min(h, int(std::ceil(hi.y))); ++y) {
        for (int x = std::max(0, int(lo.x)); x < std::min(w, int(std::ceil(hi.x))); ++x) {
          for (int k = 0; k < 16 && !used[size_t(y) * size_t(w) + size_t(x)]; ++k) {
            const glm::dvec2 p(x + (k % 4 + 0.5) / 4, y + (k / 4 + 0.5) / 4);
            const double u = ((p.x - a.x) * (c.y - a.y) - (p.y - a.y) * (c.x - a.x)) / det;
            const double v = ((b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x)) / det;
            if (u >= 0 && v >= 0 && u + v <= 1) used[size_t(y) * size_t(w) + size_t(x)] = 1;
          }
        }
      }
    }
  }
  std::vector<double> weight(used.size(), 0.0);
  for (size_t e = 0; e < s->elementCount(); ++e) {
    const glm::dvec3 rho = s->reflectance[e];
    const uint32_t texel = s->atlas.element_texel[e];
    if (!used[texel] || std::max({rho.x, rho.y, rho.z}) < 0.02) continue;
    weight[texel] = s->coverageOf(e);
  }
  return weight;
}

struct Lightmap {
  std::vector<double> luminance;
  double seconds = 0.0;
  double density = 0.0;  // texels per metre
};

// The bake at the method's defaults (the atlas's density is the scene's default too).
Lightmap bake(const std::string& room, const fs::path& out, const std::string& method,
              const std::string& extra) {
  const auto r = runCli("bake " + room + " --method " + method + " --quiet " + extra + " --stats " +
                        (out.string() + ".json") + " -o " + out.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  Lightmap m;
  Expected<Image> img = readImage((out / "room_lightmap.exr").string());
  EXPECT_TRUE(img.ok());
  if (!img) return m;
  for (const glm::vec3& p : img->pixels) m.luminance.push_back(double(luminance(p)));
  const json stats = test::readJson(out.string() + ".json");
  m.seconds = stats.value("seconds", 0.0);
  m.density = stats["atlas"].value("texel_density", 0.0);
  return m;
}

// Weighted mean of a, and RMS of a - b over the weighted mean of b.
double weightedMean(const std::vector<double>& a, const std::vector<double>& w) {
  double s = 0.0, ws = 0.0;
  for (size_t i = 0; i < a.size(); ++i) s += w[i] * a[i], ws += w[i];
  return s / ws;
}
double weightedRms(const std::vector<double>& a, const std::vector<double>& b,
                   const std::vector<double>& w) {
  double s = 0.0, ws = 0.0;
  for (size_t i = 0; i < a.size(); ++i) s += w[i] * (a[i] - b[i]) * (a[i] - b[i]), ws += w[i];
  return std::sqrt(s / ws) / weightedMean(b, w);
}

// Progressive and matrix radiosity at their defaults against two path-traced bakes of the same
// atlas (seeds 1 and 2, tolerance 0.02, at most 1,024 samples a texel: about 20 s each). The
// reference is the two bakes' mean, whose own noise their difference measures: with independent
// noise, E|m - mean|^2 = E|m - truth|^2 + E|a - b|^2 / 4, so the error against the truth is
// estimated as sqrt(rms(m - mean)^2 - rms(a - b)^2 / 4).
TEST(BakeRoomAccuracy, RadiosityLightmapsAreWithinFivePercentOfThePathTracedBake) {
  TempDir dir;
  const std::string room = std::string(PENUMBRA_SOURCE_DIR) + "/scenes/textured_room/room.glb";
  Expected<Scene> scene = loadScene(room);
  ASSERT_TRUE(scene.ok()) << scene.error().describe();
  const std::string reference = "--tolerance 0.02 --texel-samples 1024 --seed ";
  const Lightmap a = bake(room, dir.path() / "pt1", "pathtrace", reference + "1");
  const Lightmap b = bake(room, dir.path() / "pt2", "pathtrace", reference + "2");
  const std::vector<double> w = texelWeights(*scene, a.density, dir.path() / "pt1" / "room.gltf");
  ASSERT_EQ(a.luminance.size(), w.size());
  ASSERT_EQ(b.luminance.size(), w.size());
  std::vector<double> ref(w.size());
  for (size_t i = 0; i < w.size(); ++i) ref[i] = 0.5 * (a.luminance[i] + b.luminance[i]);
  const double noise = weightedRms(a.luminance, b.luminance, w);
  std::printf("%.1f texels/m; path-traced bakes %.1f s and %.1f s, %.2f%% RMS apart\n", a.density,
              a.seconds, b.seconds, 100 * noise);
  for (const char* method : {"progressive", "matrix"}) {
    const Lightmap m = bake(room, dir.path() / method, method, "");
    ASSERT_EQ(m.luminance.size(), w.size());
    const double rms = weightedRms(m.luminance, ref, w);
    const double corrected = std::sqrt(std::max(0.0, rms * rms - noise * noise / 4));
    const double mean = weightedMean(m.luminance, w) / weightedMean(ref, w);
    std::printf("%s: %.2f s, mean %.4f, %.2f%% RMS from the reference, %.2f%% from the truth\n",
                method, m.seconds, mean, 100 * rms, 100 * corrected);
    EXPECT_LT(corrected, 0.05) << method;
    EXPECT_NEAR(mean, 1.0, 0.02) << method;
  }
}

}  // namespace
}  // namespace penumbra
