// The kept view (LightmapView: the camera's hits traced once, then only lookups) against the
// streaming one (renderLightmapView): the same image bit for bit, at one and at several jittered
// samples per pixel, for successive lightmaps of a solve.
#include "penumbra/render/lightmap_view.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/radiosity/progressive.h"

#include <gtest/gtest.h>

#include <cstring>

namespace penumbra {
namespace {

TEST(LightmapView, KeptHitsGiveTheStreamingViewBitForBit) {
  Expected<Scene> scene = loadScene("cornell");
  ASSERT_TRUE(scene.ok());
  ProgressiveOptions po;
  po.atlas.texel_density = progressiveTexelDensity(*scene, 3000);
  Expected<ProgressiveRadiosity> solver = ProgressiveRadiosity::build(*scene, po);
  ASSERT_TRUE(solver.ok());
  const RadiositySurface& s = solver->surface();
  for (const int spp : {1, 3}) {
    const LightmapViewSettings settings{40, 30, spp, 7};
    const LightmapView kept(s.flat.positions, s.flat.triangles, s.atlas, *scene->camera, settings);
    for (int shots = 0; shots < 3; ++shots) {
      solver->step();
      const Image lightmap = solver->radianceImage(false);
      const Image a = kept.render(lightmap);
      const Image b = renderLightmapView(s.flat.positions, s.flat.triangles, s.atlas, lightmap,
                                         *scene->camera, settings);
      ASSERT_EQ(a.pixels.size(), b.pixels.size());
      double sum = 0.0;
      for (const glm::vec3& p : b.pixels) sum += p.x;
      EXPECT_GT(sum, 0.0);
      EXPECT_EQ(std::memcmp(a.pixels.data(), b.pixels.data(), a.pixels.size() * sizeof(glm::vec3)),
                0)
          << spp << " spp, shot " << shots;
    }
  }
}

}  // namespace
}  // namespace penumbra
