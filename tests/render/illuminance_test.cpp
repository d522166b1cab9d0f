// Illuminance for lighting design (render/illuminance.h): the work-plane grid and its figures,
// and an empty room lit by a manufacturer's downlight, where the floor's average illuminance
// from progressive radiosity agrees with the path tracer (3%) and with the flux-transfer
// estimate lighting designers use (5%: three surfaces of uniform radiosity exchanging flux
// through exact rectangle form factors, the direct flux from the luminaire's file).
#include "penumbra/render/illuminance.h"
#include "penumbra/io/luminaire_io.h"
#include "penumbra/radiosity/progressive.h"
#include "penumbra/raytrace/path_tracer.h"
#include "penumbra/render/lightmap_view.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <cmath>
#include <cstdio>
#include <numbers>

namespace penumbra {
namespace {

using test::addQuad;

constexpr double kPi = std::numbers::pi;
constexpr double kW = 4.0, kD = 5.0, kH = 3.0;  // room width (x), depth (z), height (y), m
constexpr double kRhoFloor = 0.2, kRhoWalls = 0.5, kRhoCeiling = 0.7;

const char* kDownlight = "photometry/ledvance_biolux_dn150.ldt";

LuminaireLight downlight() {
  Expected<std::shared_ptr<const LuminaireDistribution>> ldt =
      loadLuminaireDistribution(test::dataPath(kDownlight));
  EXPECT_TRUE(ldt.ok()) << ldt.error().describe();
  LuminaireLight l;
  l.position = glm::vec3(float(kW / 2), float(kH - 0.05), float(kD / 2));
  l.distribution = *ldt;
  l.scale = glm::vec3(float((*ldt)->max_candela / kLumensPerWatt));
  return l;
}

// A closed box seen from inside: floor, ceiling and four walls, each one big quad.
Scene emptyRoom() {
  Scene s;
  s.source = "test:room";
  s.materials = {{"floor", glm::vec3(float(kRhoFloor)), glm::vec3(0.0f)},
                 {"walls", glm::vec3(float(kRhoWalls)), glm::vec3(0.0f)},
                 {"ceiling", glm::vec3(float(kRhoCeiling)), glm::vec3(0.0f)}};
  Mesh m;
  m.name = "room";
  const float w = float(kW), d = float(kD), h = float(kH);
  addQuad(m, {0, 0, 0}, {0, 0, d}, {w, 0, 0}, 0);  // floor, facing +y
  addQuad(m, {0, h, 0}, {w, 0, 0}, {0, 0, d}, 2);  // ceiling, facing -y
  addQuad(m, {0, 0, 0}, {w, 0, 0}, {0, h, 0}, 1);  // z = 0, facing +z
  addQuad(m, {0, 0, d}, {0, h, 0}, {w, 0, 0}, 1);  // z = d, facing -z
  addQuad(m, {0, 0, 0}, {0, h, 0}, {0, 0, d}, 1);  // x = 0, facing +x
  addQuad(m, {w, 0, 0}, {0, 0, d}, {0, h, 0}, 1);  // x = w, facing -x
  s.meshes.push_back(m);
  s.lights.push_back(downlight());
  return s;
}

// Howell's catalogue C-11: two directly opposed parallel a x b rectangles c apart.
double parallelRectangles(double a, double b, double c) {
  const double x = a / c, y = b / c;
  const double x2 = 1.0 + x * x, y2 = 1.0 + y * y;
  return 2.0 / (kPi * x * y) *
         (0.5 * std::log(x2 * y2 / (x2 + y2 - 1.0)) +
          x * std::sqrt(y2) * std::atan(x / std::sqrt(y2)) +
          y * std::sqrt(x2) * std::atan(y / std::sqrt(x2)) - x * std::atan(x) - y * std::atan(y));
}

TEST(Illuminance, LuxOfWhiteIrradianceIs683TimesIt) {
  EXPECT_NEAR(luxOf(glm::dvec3(1.0)), 683.0, 1e-9);
  EXPECT_NEAR(luxOf(glm::dvec3(0.0, 1.0, 0.0)), 683.0 * 0.7152, 1e-9);
  const double lux[] = {100.0, 300.0, 200.0};
  const IlluminanceStats s = illuminanceStats(lux);
  EXPECT_DOUBLE_EQ(s.average, 200.0);
  EXPECT_DOUBLE_EQ(s.minimum, 100.0);
  EXPECT_DOUBLE_EQ(s.maximum, 300.0);
  EXPECT_DOUBLE_EQ(s.uniformity, 0.5);
}

TEST(Illuminance, WorkPlaneGridFitsTheRoom) {
  const Scene room = emptyRoom();
  Expected<CalculationGrid> g = workPlaneGrid(room, 0.75, 0.3, 0.5);
  ASSERT_TRUE(g.ok()) << g.error().describe();
  // 3 m x 4 m inside the margin: 10 x 14 cells of 0.3 x 0.286 m, points at their centres.
  EXPECT_EQ(g->columns, 10);
  EXPECT_EQ(g->rows, 14);
  ASSERT_EQ(g->points.size(), 140u);
  EXPECT_NEAR(g->points.front().x, 0.5 + 0.15, 1e-12);
  EXPECT_NEAR(g->points.front().y, 0.75, 1e-12);
  EXPECT_NEAR(g->points.back().z, kD - 0.5 - 0.5 * 4.0 / 14.0, 1e-12);
  EXPECT_FALSE(workPlaneGrid(room, 0.75, 0.0, 0.0).ok());
  EXPECT_FALSE(workPlaneGrid(room, 0.75, 0.3, 2.0).ok());   // the margin leaves nothing
  EXPECT_FALSE(workPlaneGrid(room, 0.75, 1e-4, 0.0).ok());  // 2e9 points
}

TEST(Illuminance, EmptyRoomFloorAgreesWithThePathTracerAndTheFluxTransferEstimate) {
  const Scene room = emptyRoom();
  const LuminaireLight& lum = std::get<LuminaireLight>(room.lights[0]);
  Expected<Photometry> photometry = readPhotometry(test::dataPath(kDownlight));
  ASSERT_TRUE(photometry.ok());

  // The flux transfer estimate. Direct flux onto the floor and the walls: the file's intensity
  // integrated over each surface's solid angle (midpoint rule, 1 cm cells); the ceiling gets
  // the rest (nothing, for a downlight).
  const glm::dvec3 source(lum.position);
  auto direct_flux = [&](glm::dvec3 o, glm::dvec3 u, glm::dvec3 v, int nu, int nv) {
    const glm::dvec3 n = glm::normalize(glm::cross(u, v));
    const double da = glm::length(u) * glm::length(v) / (double(nu) * nv);
    double flux = 0.0;
    for (int i = 0; i < nu; ++i) {
      for (int j = 0; j < nv; ++j) {
        const glm::dvec3 p = o + u * ((i + 0.5) / nu) + v * ((j + 0.5) / nv);
        const glm::dvec3 d = p - source;
        const double r = glm::length(d);
        // The photometric frame: nadir -z, C0 +x, C90 = c0 x nadir (+z of the room is -y there).
        const glm::dvec3 local(d.x, -d.z, d.y);
        flux += photometry->intensity(local) * std::abs(glm::dot(n, d)) / (r * r * r) * da;
      }
    }
    return flux;
  };
  const double total = photometry->integratedFlux();
  const double to_floor = direct_flux({0, 0, 0}, {kW, 0, 0}, {0, 0, kD}, 400, 500);
  const double to_walls = 2.0 * direct_flux({0, 0, 0}, {kW, 0, 0}, {0, kH, 0}, 400, 300) +
                          2.0 * direct_flux({0, 0, 0}, {0, 0, kD}, {0, kH, 0}, 500, 300);
  const double to_ceiling = std::max(0.0, total - to_floor - to_walls);
  // Exchange between floor (f), ceiling (c) and the walls (w) taken as one surface.
  const double af = kW * kD, aw = 2.0 * (kW + kD) * kH;
  const double ffc = parallelRectangles(kW, kD, kH), ffw = 1.0 - ffc;
  const double fwf = ffw * af / aw, fww = 1.0 - 2.0 * fwf;
  // Incident flux: phi = direct + sum_j rho_j phi_j F_ji, solved by iteration.
  double pf = to_floor, pw = to_walls, pc = to_ceiling;
  for (int k = 0; k < 200; ++k) {
    const double nf = to_floor + kRhoCeiling * pc * ffc + kRhoWalls * pw * fwf;
    const double nc = to_ceiling + kRhoFloor * pf * ffc + kRhoWalls * pw * fwf;
    const double nw =
        to_walls + kRhoFloor * pf * ffw + kRhoCeiling * pc * ffw + kRhoWalls * pw * fww;
    pf = nf;
    pc = nc;
    pw = nw;
  }
  const double flux_transfer = pf / af;
  const double direct_estimate = to_floor / af;

  // The floor as a grid of points 10 cm apart.
  Expected<CalculationGrid> grid = workPlaneGrid(room, 0.0, 0.1, 0.0);
  ASSERT_TRUE(grid.ok());

  ProgressiveOptions o;
  o.atlas.texel_density = 8.0;
  o.convergence = 1e-4;
  Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(room, o);
  ASSERT_TRUE(pr.ok()) << pr.error().describe();
  pr->solve();
  const Image lightmap = pr->radianceImage();
  const LightmapLookup lookup(pr->triangles().positions, pr->triangles().triangles, pr->atlas(),
                              lightmap);
  const IlluminanceResult radiosity = gatherIlluminance(
      room, pr->surface().engine, pr->triangles(), *grid,
      [&](const Ray& ray, const Hit& hit, Rng&) {
        return lookup.radiance(ray.dir, hit.triangle, hit.u, hit.v);
      },
      256, 1);

  const PathTracer pt(room);
  PathTracerSettings settings;
  const IlluminanceResult traced = gatherIlluminance(
      room, pr->surface().engine, pr->triangles(), *grid,
      [&](const Ray& ray, const Hit&, Rng& rng) {
        uint64_t rays = 0;
        return pt.radiance(ray, rng, settings, rays);
      },
      256, 2);

  std::printf(
      "floor: direct %.2f lx (file integral %.2f); total: radiosity %.2f, path tracer %.2f, "
      "flux transfer %.2f lx; U0 %.3f\n",
      radiosity.direct_stats.average, direct_estimate, radiosity.total_stats.average,
      traced.total_stats.average, flux_transfer, radiosity.total_stats.uniformity);
  // The grid's direct part is the luminaire alone: the file's integral within the grid's
  // sampling of it.
  EXPECT_NEAR(radiosity.direct_stats.average / direct_estimate, 1.0, 0.01);
  EXPECT_EQ(radiosity.direct, traced.direct);  // the same delta-light term on both
  EXPECT_NEAR(radiosity.total_stats.average / traced.total_stats.average, 1.0, 0.03);
  EXPECT_NEAR(radiosity.total_stats.average / flux_transfer, 1.0, 0.05);
  // Interreflection adds about 8% here (a dark floor under a downlight): the comparisons see it.
  EXPECT_GT(radiosity.total_stats.average, 1.05 * radiosity.direct_stats.average);
}

}  // namespace
}  // namespace penumbra
