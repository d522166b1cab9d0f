// Seams (radiosity/lightmap_seams.h): a sphere lit by a point light is cut into charts, and a
// lookup on either side of a cut must read the same light. The sphere's irradiance has a closed
// form, E = I cos(theta) / d^2 on its lit side (a convex surface sees none of itself), so the
// stitched lightmap is checked against physics as well as for the jumps it removes.
#include "penumbra/io/image_io.h"
#include "penumbra/io/scene_io.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <glm/geometric.hpp>

namespace penumbra {
namespace {

namespace fs = std::filesystem;
using test::runCli;
using test::TempDir;

TEST(BakeSeams, StitchingASpheresSeamsRemovesTheJumpsAndKeepsTheClosedForm) {
  TempDir dir;
  const std::string scene = dir.write("sphere.json",
                                      R"({"materials": {"grey": {"reflectance": [0.5, 0.5, 0.5]}},
          "meshes": [{"sphere": 4, "material": "grey"}],
          "lights": [{"type": "point", "position": [0.5, 3, 0.3], "intensity": [10, 10, 10]}]})");
  const auto bake = [&](const std::string& seams) {
    const fs::path out = dir.path() / seams;
    const auto r =
        runCli("bake " + scene + " --method progressive --texel-density 16 --seams " + seams +
               " --quiet -o " + out.string() + " --stats " + (out / "stats.json").string());
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return test::readJson((out / "stats.json").string())["seams"];
  };
  const nlohmann::json off = bake("off");
  const nlohmann::json on = bake("stitch");
  std::printf("seams: %d edges; largest jump %.4g -> %.4g W/m^2, RMS %.4g -> %.4g\n",
              on["edges"].get<int>(), on["largest_jump_before"].get<double>(),
              on["largest_jump_after"].get<double>(), on["rms_jump_before"].get<double>(),
              on["rms_jump_after"].get<double>());
  ASSERT_GT(on["edges"].get<int>(), 50);
  EXPECT_EQ(off["largest_jump_before"], on["largest_jump_before"]);  // the same solve
  EXPECT_LT(on["largest_jump_after"].get<double>(), 0.3 * on["largest_jump_before"].get<double>());
  EXPECT_LT(on["rms_jump_after"].get<double>(), 0.2 * on["rms_jump_before"].get<double>());

  // Both against the closed form, through each file's own lightmap UVs: at the midpoint of
  // every edge (where the seams are) and the centroid of every triangle on the lit side away
  // from the terminator, E = I cos(theta) / d^2 with the sphere's own normal.
  const auto errors = [&](const std::string& seams) {
    const fs::path out = dir.path() / seams;
    Expected<Image> e = readImage((out / "sphere_lightmap.exr").string());
    Expected<Scene> baked = loadScene((out / "sphere.gltf").string());
    std::pair<double, double> mean_max{0.0, 0.0};
    if (!e.ok() || !baked.ok()) return mean_max;
    const Mesh& m = baked->meshes.at(0);
    const std::vector<glm::vec2>& uv = m.uvSet(1);
    const glm::dvec3 light(0.5, 3, 0.3);
    double sum = 0.0;
    size_t n = 0;
    for (const glm::uvec3& t : m.triangles) {
      for (const glm::dvec3 w : {glm::dvec3(1, 1, 1) / 3.0, glm::dvec3(0.5, 0.5, 0),
                                 glm::dvec3(0, 0.5, 0.5), glm::dvec3(0.5, 0, 0.5)}) {
        const glm::dvec3 p = w.x * glm::dvec3(m.positions[t.x]) +
                             w.y * glm::dvec3(m.positions[t.y]) +
                             w.z * glm::dvec3(m.positions[t.z]);
        const glm::dvec3 to = light - p;
        const double cosine = glm::dot(glm::normalize(p), glm::normalize(to));
        if (cosine < 0.3) continue;
        const double want = 10.0 * cosine / glm::dot(to, to);
        const glm::vec2 at = float(w.x) * uv[t.x] + float(w.y) * uv[t.y] + float(w.z) * uv[t.z];
        const double got = test::bilinear(*e, at).y;
        const double rel = std::abs(got - want) / want;
        sum += rel;
        ++n;
        mean_max.second = std::max(mean_max.second, rel);
      }
    }
    mean_max.first = n ? sum / double(n) : 1.0;
    return mean_max;
  };
  const auto [mean_off, max_off] = errors("off");
  const auto [mean_on, max_on] = errors("stitch");
  std::printf("against I cos / d^2: mean %.2f%% -> %.2f%%, worst %.2f%% -> %.2f%%\n",
              100 * mean_off, 100 * mean_on, 100 * max_off, 100 * max_on);
  EXPECT_LT(mean_on, 0.02);
  EXPECT_LE(mean_on, mean_off * 1.05);
  EXPECT_LT(max_on, max_off);
}

}  // namespace
}  // namespace penumbra
