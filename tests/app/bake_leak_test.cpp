// Light leaking through a wall (radiosity/texel_footprint.h): two rooms share a 2 cm wall, one
// lit by a bright ceiling panel, the other by a panel a hundred times dimmer, and the floor runs
// under the wall as one quad, so texels straddle it. Every texel of the dark room's floor near the
// wall stays as dark as the room, and progressive radiosity's lightmap agrees with the
// path-traced bake there texel by texel.
#include "penumbra/io/image_io.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/radiosity/radiosity_surface.h"
#include "support/test_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

namespace penumbra {
namespace {

namespace fs = std::filesystem;
using test::runCli;
using test::TempDir;

double lum(const glm::vec3& c) {
  return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
}

// Progressive radiosity's bands by the wall against the path-traced bake. Its shooters are
// clusters of the hierarchy, and where the floor's chart runs under the wall a cluster holds
// texels of both rooms: the dark room's part of its light leaves from the cluster's point in
// the lit room. The dark room comes out 8-10% dark by the wall (docs/performance.md, "Leaks").
constexpr double kBandTolerance = 0.12;

TEST(BakeLeaks, TheDarkRoomNextToALitOneStaysDarkUpToTheWall) {
  const std::string scene_path =
      std::string(PENUMBRA_SOURCE_DIR) + "/scenes/two_rooms/two_rooms.json";
  TempDir dir;
  const auto bakeWith = [&](const std::string& method) {
    const fs::path out = dir.path() / method;
    // Progressive radiosity converged well below its default unshot fraction (0.1% of all the
    // power, a tenth of what the dim room gets): the leaks are measured, not the stopping rule.
    const std::string converged = method == "progressive" ? " --tolerance 1e-5" : "";
    const auto r = runCli("bake " + scene_path + " --method " + method + converged +
                          " --texel-density 10 --quiet -o " + out.string());
    EXPECT_EQ(r.exit_code, 0) << r.output;
    Expected<Image> lightmap = readImage((out / "two_rooms_lightmap.exr").string());
    EXPECT_TRUE(lightmap.ok());
    return lightmap.ok() ? *lightmap : Image{};
  };
  const Image reference = bakeWith("pathtrace");
  const Image progressive = bakeWith("progressive");

  // The same atlas in this process: which texel lies where, and whose point moved.
  Expected<Scene> scene = loadScene(scene_path);
  ASSERT_TRUE(scene.ok());
  LightmapResolution resolution;
  resolution.texel_density = 10.0;
  Expected<ChartAtlasOptions> options = lightmapAtlasOptions(*scene, resolution);
  ASSERT_TRUE(options.ok());
  Expected<RadiositySurface> surface = RadiositySurface::build(*scene, *options, true);
  ASSERT_TRUE(surface.ok()) << surface.error().describe();
  ASSERT_EQ(surface->atlas.width, reference.width);
  ASSERT_EQ(surface->atlas.height, reference.height);
  ASSERT_EQ(progressive.pixels.size(), reference.pixels.size());

  // The dark room's floor in bands 0.1 m wide by the distance of the texel's point from the
  // wall, and away from it. Bands, not texels: the path-traced reference's texels there carry
  // about 10% noise (its stopping rule's floor is a tenth of the lightmap's mean, which the lit
  // room sets), its bands about 1%.
  double ref[3] = {}, got[3] = {}, far_ref = 0.0, worst = 0.0;
  size_t count[3] = {}, far = 0;
  for (size_t e = 0; e < surface->elementCount(); ++e) {
    const glm::dvec3 p = surface->atlas.element_position[e];
    if (std::abs(p.y) > 1e-6 || surface->atlas.element_normal[e].y < 0.9) continue;  // floor
    const size_t t = surface->atlas.element_texel[e];
    const double r = lum(reference.pixels[t]), g = lum(progressive.pixels[t]);
    const double d = -0.01 - p.x;  // from the wall's dark face
    if (d >= 0.0 && d < 0.3) {
      const int band = std::min(2, int(d / 0.1));
      ref[band] += r;
      got[band] += g;
      ++count[band];
      worst = std::max({worst, r, g});
    } else if (p.x < -0.8 && p.x > -1.5) {
      ++far;
      far_ref += r;
    }
  }
  ASSERT_GT(far, 100u);
  far_ref /= double(far);
  for (int band = 0; band < 3; ++band) {
    ASSERT_GT(count[band], 20u) << band;
    ref[band] /= double(count[band]);
    got[band] /= double(count[band]);
    std::printf(
        "dark room floor %.1f-%.1f m from the wall (%zu texels): path traced %.4g, "
        "progressive %.4g W/m^2 (%+.1f%%)\n",
        0.1 * band, 0.1 * (band + 1), count[band], ref[band], got[band],
        100.0 * (got[band] / ref[band] - 1.0));
    // Texels by the wall agree with the path-traced bake, band by band.
    EXPECT_NEAR(got[band] / ref[band], 1.0, kBandTolerance) << band;
    // And no light from next door: the room's own level, not tens of times it.
    EXPECT_LT(ref[band], 1.2 * far_ref) << band;
  }
  std::printf("away from the wall: %.4g W/m^2; brightest texel by the wall %.4g\n", far_ref, worst);
  EXPECT_LT(worst, 1.5 * far_ref);
}

// A texel whose point lies under a wall standing across it moves its point to the side most of
// its footprint is on, where a bilinear lookup of its value is read.
TEST(BakeLeaks, ATexelsPointUnderAWallMovesToTheLargerSide) {
  Scene scene;
  scene.source = "wall";
  scene.materials.push_back(Material{"grey", glm::vec3(0.5f), glm::vec3(0.0f)});
  const auto quad = [&](glm::vec3 a, glm::vec3 b, glm::vec3 c, glm::vec3 d) {
    Mesh m;
    m.name = "quad" + std::to_string(scene.meshes.size());
    m.positions = {a, b, c, d};
    m.triangles = {{0, 1, 2}, {0, 2, 3}};
    m.material_ids = {0, 0};
    scene.meshes.push_back(m);
  };
  // A 1 m floor facing up, and across it a wall slab 4 cm thick, 0.03 m off the centre.
  quad({0, 0, 1}, {1, 0, 1}, {1, 0, 0}, {0, 0, 0});
  for (const float x : {0.49f, 0.53f}) {
    const float s = x < 0.5f ? -1.0f : 1.0f;  // each face facing out of the slab
    quad({x, 0, s > 0 ? 0.0f : 1.0f}, {x, 0, s > 0 ? 1.0f : 0.0f}, {x, 1, s > 0 ? 1.0f : 0.0f},
         {x, 1, s > 0 ? 0.0f : 1.0f});
  }
  ASSERT_TRUE(validateScene(scene).ok());
  ChartAtlasOptions options;
  options.texel_density = 1.0;  // the floor is about one texel
  Expected<RadiositySurface> surface = RadiositySurface::build(scene, options, false);
  ASSERT_TRUE(surface.ok()) << surface.error().describe();
  size_t floor_elements = 0;
  for (size_t e = 0; e < surface->elementCount(); ++e) {
    const glm::dvec3 p = surface->atlas.element_position[e];
    if (surface->atlas.element_normal[e].y < 0.9 || p.y > 1e-6) continue;
    if (surface->atlas.element_area[e] < 0.5) continue;  // the texel the wall crosses
    ++floor_elements;
    // Not under the slab, and on its larger side (x < 0.49, 49% of the floor against 47%).
    EXPECT_TRUE(p.x < 0.49 || p.x > 0.53) << p.x;
  }
  EXPECT_EQ(floor_elements, 1u);
  EXPECT_GE(surface->anchored, 1u);
}

}  // namespace
}  // namespace penumbra
