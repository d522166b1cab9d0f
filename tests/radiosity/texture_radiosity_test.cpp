// Textures and cut-outs in the radiosity methods against closed forms: in the chequered furnace
// every element reflects its footprint's mean albedo and the area-mean radiosity is
// pi Le / (1 - rho_mean) (progressive and matrix radiosity), and the view brings the chequer's
// detail back; a half-masked occluder lets half the sun reach the floor; an emissive texture's
// flux is its mean times its area.
#include "penumbra/radiosity/matrix_radiosity.h"
#include "penumbra/radiosity/progressive.h"
#include "penumbra/raytrace/camera_rays.h"
#include "penumbra/raytrace/scene_geometry.h"
#include "penumbra/render/lightmap_view.h"
#include "penumbra/scene/builtin.h"
#include "support/textured_scenes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

namespace penumbra {
namespace {

constexpr double kPi = std::numbers::pi;

std::vector<glm::dvec3> radiosityOf(const ProgressiveRadiosity& pr) {
  std::vector<glm::dvec3> b(pr.elementCount());
  for (size_t e = 0; e < b.size(); ++e) b[e] = pr.radiosity(e);
  return b;
}

// Inside the furnace (the faces' fronts): the area-weighted means of radiosity and reflectance.
struct FurnaceMeans {
  double radiosity = 0.0;
  double reflectance = 0.0;
};

TEST(TextureRadiosity, ChequeredFurnaceTakesTheMeanAlbedo) {
  const Scene s = test::chequeredFurnace(100, 200);
  const double rho_mean = s.materials[0].reflectance_texture->texture->mean().x;
  const double expected = kPi / (1.0 - rho_mean);
  ProgressiveOptions o;
  o.atlas.texel_density = 2.0;  // elements of 2 x 2 chequer cells
  o.convergence = 1e-4;
  o.max_iterations = 4000;
  Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(s, o);
  ASSERT_TRUE(pr.ok()) << pr.error().describe();
  ASSERT_TRUE(pr->solve().converged);
  FurnaceMeans m;
  double area = 0.0, worst_rho = 0.0;
  for (size_t e = 0; e < pr->elementCount(); ++e) {
    if (pr->atlas().faces[pr->atlas().element_face[e]].back) continue;
    const double a = pr->elementArea(e);
    m.radiosity += a * pr->radiosity(e).x;
    m.reflectance += a * pr->reflectance(e).x;
    area += a;
    // An element two cells wide holds half of each shade, whatever its offset.
    if (a > 0.99 * 0.25)
      worst_rho = std::max(worst_rho, std::abs(pr->reflectance(e).x / rho_mean - 1));
  }
  m.radiosity /= area;
  m.reflectance /= area;
  std::printf(
      "chequered furnace: progressive mean B %.4f (closed form %.4f), mean rho %.4f "
      "(texture %.4f), worst full element rho %.4f\n",
      m.radiosity, expected, m.reflectance, rho_mean, worst_rho);
  EXPECT_NEAR(m.reflectance / rho_mean, 1.0, 0.005);
  EXPECT_LT(worst_rho, 0.02);
  EXPECT_NEAR(m.radiosity / expected, 1.0, 0.01);

  // The view: irradiance from the lightmap, albedo from the texture at each pixel.
  const auto detail = pr->surface().lightmapDetail();
  ASSERT_NE(detail, nullptr);
  LightmapViewSettings view;
  view.width = view.height = 32;
  view.spp = 16;
  const Image img =
      renderLightmapView(pr->triangles().positions, pr->triangles().triangles, pr->atlas(),
                         pr->radianceImage(), *s.camera, view, detail.get());
  const SceneGeometry g = SceneGeometry::build(s);
  const CameraRays rays(*s.camera, view.width, view.height);
  double got = 0.0, want = 0.0;
  int light_cells = 0, dark_cells = 0;
  for (int y = 0; y < view.height; ++y) {
    for (int x = 0; x < view.width; ++x) {
      const Hit h = g.engine.intersect(rays.ray(float(x) + 0.5f, float(y) + 0.5f));
      const double rho = g.reflectanceAt(uint32_t(h.triangle), h.u, h.v).x;
      const double w = 1.0 + rho / (1.0 - rho_mean);
      got += img.at(x, y).x;
      want += w;
      // A pixel in the middle of a cell shows that cell's shade.
      if (std::abs(img.at(x, y).x / w - 1.0) < 0.08) (rho > rho_mean ? light_cells : dark_cells)++;
    }
  }
  EXPECT_NEAR(got / want, 1.0, 0.02);
  EXPECT_GT(light_cells, 300);
  EXPECT_GT(dark_cells, 300);

  // Matrix radiosity on the same surface model.
  MatrixRadiosityOptions mo;
  mo.elements = 600;
  mo.lightmap.texel_density = 2.0;
  Expected<MatrixRadiosity> mr = buildMatrixRadiosity(s, mo);
  ASSERT_TRUE(mr.ok()) << mr.error().describe();
  SolveOptions so;
  so.tolerance = 1e-8;
  so.max_iterations = 400;
  ASSERT_TRUE(mr->solve(so).converged);
  const std::vector<glm::dvec3> b = mr->elementRadiosity(false);
  double mb = 0.0, ma = 0.0;
  for (size_t e = 0; e < b.size(); ++e) {
    if (mr->surface.atlas.faces[mr->surface.atlas.element_face[e]].back) continue;
    mb += mr->surface.atlas.element_area[e] * b[e].x;
    ma += mr->surface.atlas.element_area[e];
  }
  std::printf("chequered furnace: matrix mean B %.4f (closed form %.4f)\n", mb / ma, expected);
  EXPECT_NEAR(mb / ma / expected, 1.0, 0.01);
}

// The furnace with a lattice inside that is all holes: light passes it untouched, so every wall
// element keeps 2 pi. The lattice's elements still have area and receive irradiance; the power
// books and the closure of shots and rows must count only what they intercept (none of it).
TEST(TextureRadiosity, AnOpenLatticeInTheFurnaceChangesNothing) {
  Scene s = *builtinScene("furnace");
  Material open = test::maskedLattice(AlphaMode::kMask);
  open.alpha = 0.0f;  // nothing covered
  s.materials.push_back(open);
  Mesh lattice;
  lattice.name = "lattice";
  lattice.positions = {{-0.5f, 0, 0.5f}, {0.5f, 0, 0.5f}, {0.5f, 0, -0.5f}, {-0.5f, 0, -0.5f}};
  lattice.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  lattice.triangles = {{0, 1, 2}, {0, 2, 3}};
  lattice.material_ids = {1, 1};
  s.meshes.push_back(lattice);
  ASSERT_TRUE(validateScene(s).ok());
  const double expected = 2.0 * kPi;
  auto worstWall = [&](auto radiosity, const ChartAtlas& atlas, size_t n) {
    double worst = 0.0;
    for (size_t e = 0; e < n; ++e) {
      const SurfaceFace& face = atlas.faces[atlas.element_face[e]];
      if (face.back || face.triangle >= 12) continue;  // the cube's inside
      worst = std::max(worst, std::abs(radiosity(e) / expected - 1.0));
    }
    return worst;
  };
  ProgressiveOptions o;
  o.atlas.texel_density = 6.0;
  o.convergence = 1e-4;
  o.max_iterations = 4000;
  Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(s, o);
  ASSERT_TRUE(pr.ok()) << pr.error().describe();
  ASSERT_TRUE(pr->solve().converged);
  EXPECT_LT(
      worstWall([&](size_t e) { return pr->radiosity(e).x; }, pr->atlas(), pr->elementCount()),
      0.03);
  MatrixRadiosityOptions mo;
  mo.elements = 600;
  mo.lightmap.texel_density = 6.0;
  Expected<MatrixRadiosity> mr = buildMatrixRadiosity(s, mo);
  ASSERT_TRUE(mr.ok()) << mr.error().describe();
  SolveOptions so;
  so.tolerance = 1e-8;
  so.max_iterations = 400;
  ASSERT_TRUE(mr->solve(so).converged);
  const std::vector<glm::dvec3> b = mr->elementRadiosity(false);
  EXPECT_LT(worstWall([&](size_t e) { return b[e].x; }, mr->surface.atlas, b.size()), 0.03);
}

TEST(TextureRadiosity, HalfMaskedQuadCastsHalfTheShadow) {
  const Scene s = test::floorUnderOccluder(test::maskedLattice(AlphaMode::kMask), 2.0f);
  ProgressiveOptions o;
  o.atlas.texel_density = 16.0;  // elements of 1/4 of a cell
  Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(s, o);
  ASSERT_TRUE(pr.ok()) << pr.error().describe();
  pr->solve();
  // The floor under the lattice: B = rho E vis (the lattice is black: no other light).
  const double expected = 0.5 * 2.0 * 0.5;
  EXPECT_NEAR(test::floorMeanUnder(pr->atlas(), radiosityOf(*pr)), expected, 0.03 * expected);
  // The lattice's own elements reflect only where it is there.
  for (size_t e = 0; e < pr->elementCount(); ++e) {
    if (pr->elementPosition(e).y > 0.5) {
      EXPECT_EQ(pr->reflectance(e), glm::dvec3(0.0));
    }
  }
}

// The floor under a lattice lit by an area emitter: every ray from the emitter to it crosses the
// lattice, so a half-open lattice passes half the light (0.5003 by Monte Carlo over the pairs of
// points). The receivers' and the shooter points' grids line up with the lattice's cells at
// these densities; with rays from the points' centres the half-open lattice passed 26% (6
// texels/m) to 43% (24 texels/m), the samples landing on the cells' edges (radiosity/
// cutout_jitter.h).
TEST(TextureRadiosity, AHalfOpenLatticePassesHalfAnAreaLightsLight) {
  const Material half = test::maskedLattice(AlphaMode::kMask);
  Material open = half;
  open.alpha = 0.0f;
  for (const double density : {6.0, 24.0}) {
    double floor[2] = {};
    for (int k = 0; k < 2; ++k) {
      ProgressiveOptions o;
      o.atlas.texel_density = density;
      Expected<ProgressiveRadiosity> pr =
          ProgressiveRadiosity::build(test::emitterOverLattice(k == 0 ? open : half), o);
      ASSERT_TRUE(pr.ok()) << pr.error().describe();
      pr->solve();
      floor[k] = test::floorMeanUnder(pr->atlas(), radiosityOf(*pr));
    }
    std::printf("%.0f texels/m: the half-open lattice passes %.4f of the open one's light\n",
                density, floor[1] / floor[0]);
    EXPECT_NEAR(floor[1] / floor[0], 0.5, 0.01) << density;
  }
}

TEST(TextureRadiosity, EmissiveTextureFluxIsItsMeanTimesTheArea) {
  const Material screen = test::chequeredScreen();
  const Scene s = test::emitterOverFloor(screen, 2.0f);
  ProgressiveOptions o;
  o.atlas.texel_density = 8.0;
  o.max_iterations = 1;
  Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(s, o);
  ASSERT_TRUE(pr.ok()) << pr.error().describe();
  // Emitted power: pi L A per channel, L the texture's mean times the factor.
  const glm::dvec3 emitted = pr->balance().emitted;
  const double expected = kPi * 3.0 * 0.5 * 1.0;
  EXPECT_NEAR(emitted.x, expected, 0.005 * expected);
  EXPECT_NEAR(emitted.y, expected, 0.005 * expected);
  EXPECT_NEAR(emitted.z, 0.0, 1e-12);
}

}  // namespace
}  // namespace penumbra
