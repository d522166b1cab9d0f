// Progressive refinement radiosity in a lightmap atlas (Wallner, sec. 2-3): the furnace's closed
// form, exact energy bookkeeping after every iteration, shooter selection, and agreement with
// the matrix method on the Cornell box.
#include "penumbra/radiosity/progressive.h"
#include "penumbra/radiosity/matrix_radiosity.h"
#include "penumbra/radiosity/progressive_checkpoint.h"
#include "penumbra/render/lightmap_view.h"
#include "penumbra/scene/builtin.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>

namespace penumbra {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Largest relative departure, over channels, of emitted = absorbed + unshot + escaped, with the
// unshot power recomputed from the elements' residuals (not the booked running sum).
double energyIdentityError(const ProgressiveRadiosity& pr) {
  const EnergyBalance& b = pr.balance();
  const glm::dvec3 rhs = b.absorbed + pr.unshotPower() + b.escaped;
  double worst = 0.0;
  for (int c = 0; c < 3; ++c)
    worst = std::max(worst, std::abs(b.emitted[c] - rhs[c]) / b.emitted[c]);
  return worst;
}

// The face holding element e's texel centre.
const SurfaceFace& elementFace(const ProgressiveRadiosity& pr, size_t e) {
  return pr.atlas().faces[pr.atlas().element_face[e]];
}

TEST(ProgressiveRadiosity, FurnaceConvergesToTheClosedForm) {
  Expected<Scene> furnace = builtinScene("furnace");
  ASSERT_TRUE(furnace.ok());
  ProgressiveOptions o;
  o.atlas.texel_density = 6.0;  // legs of 12 texels on the 2 m^2 triangles
  o.convergence = 1e-3;
  o.max_iterations = 2000;
  Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(*furnace, o);
  ASSERT_TRUE(pr.ok()) << pr.error().describe();
  double worst_identity = 0.0;
  const ProgressiveStats st = pr->solve([&](const ProgressiveIteration&) {
    worst_identity = std::max(worst_identity, energyIdentityError(*pr));
  });
  ASSERT_TRUE(st.converged);
  EXPECT_LE(worst_identity, 1e-4);
  const double exact = 2.0 * kPi;  // E / (1 - rho) = pi * 1 / 0.5
  double worst = 0.0, mean = 0.0, worst_interior = 0.0;
  size_t inside = 0;
  for (size_t e = 0; e < pr->elementCount(); ++e) inside += elementFace(*pr, e).back ? 0 : 1;
  for (size_t e = 0; e < pr->elementCount(); ++e) {
    // The furnace's inside (its faces' fronts); the outside is two-sided paint in the dark.
    if (elementFace(*pr, e).back) {
      EXPECT_EQ(pr->radiosity(e), glm::dvec3(0.0));
      continue;
    }
    const double err = std::abs(pr->radiosity(e).x - exact) / exact;
    worst = std::max(worst, err);
    mean += err / double(inside);
    // Distance to the nearest cube edge: the smallest 1 - |c| over the two in-face coordinates.
    const glm::dvec3 p = glm::abs(pr->elementPosition(e));
    const double m = std::max({p.x, p.y, p.z});
    double edge = 1.0;
    for (int c = 0; c < 3; ++c) {
      if (p[c] < m) edge = std::min(edge, 1.0 - p[c]);
    }
    if (edge > 2.0 / o.atlas.texel_density) worst_interior = std::max(worst_interior, err);
  }
  const EnergyBalance& b = pr->balance();
  std::printf(
      "furnace: %zu elements, %d iterations, %.3f s (%.1f ms/iteration), %llu rays; B error worst "
      "%.4f mean %.4f interior (> 2 texels from an edge) %.4f; identity %.2e; escaped %.4f of "
      "emitted\n",
      pr->elementCount(), st.iterations, st.seconds, 1e3 * st.seconds / st.iterations,
      static_cast<unsigned long long>(st.rays), worst, mean, worst_interior, worst_identity,
      b.escaped.x / b.emitted.x);
  // Issue 5's bar: every element within 1% once converged. Measured at this density with the
  // hierarchical shooter (Lambert's polygon form factor up to 8 block sizes, eq. 2's disc
  // beyond): worst 0.06%, mean 0.04%. The flat scheme (every element a disc, exact only for near
  // pairs) measured worst 0.81%, mean 0.41%; with eq. 2's disc alone the edges were 10.6% off.
  EXPECT_LE(worst, 0.01);
  EXPECT_LE(worst, 0.002);
  EXPECT_LE(mean, 0.001);
  EXPECT_LE(worst_interior, 0.002);
}

TEST(ProgressiveRadiosity, EnergyBalancesAfterEveryIterationInAnOpenScene) {
  Expected<Scene> cornell = builtinScene("cornell");
  ASSERT_TRUE(cornell.ok());
  ProgressiveOptions o;
  o.atlas.texel_density = 25.0;
  o.shooter_level = 1;
  o.max_iterations = 60;
  o.convergence = 0.0;
  Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(*cornell, o);
  ASSERT_TRUE(pr.ok()) << pr.error().describe();
  double worst = 0.0, previous_fraction = 1.0;
  bool monotone = true;
  pr->solve([&](const ProgressiveIteration& it) {
    worst = std::max(worst, energyIdentityError(*pr));
    monotone = monotone && it.unshot_fraction <= previous_fraction;
    previous_fraction = it.unshot_fraction;
  });
  const EnergyBalance& b = pr->balance();
  std::printf(
      "cornell energy: identity %.2e; escaped %.3f, absorbed %.3f, unshot %.4f of emitted\n", worst,
      b.escaped.x / b.emitted.x, b.absorbed.x / b.emitted.x, b.unshot.x / b.emitted.x);
  EXPECT_LE(worst, 1e-4);
  EXPECT_TRUE(monotone);        // every shooter reflects less than it shoots (rho < 1)
  EXPECT_GT(b.escaped.x, 0.0);  // the open front lets light out
}

TEST(ProgressiveRadiosity, SelectsTheShooterWithTheHighestResidualPower) {
  Expected<Scene> cornell = builtinScene("cornell");
  ASSERT_TRUE(cornell.ok());
  ProgressiveOptions o;
  o.atlas.texel_density = 12.0;
  o.shooter_level = 1;
  Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(*cornell, o);
  ASSERT_TRUE(pr.ok()) << pr.error().describe();
  // The first shooter is the light's chart; then brute force agrees with the selection.
  const uint32_t first = pr->selectShooter();
  ASSERT_LT(first, pr->shooterCount());
  EXPECT_NE(pr->emission(pr->shooterBegin(first)), glm::dvec3(0.0));
  for (int i = 0; i < 6; ++i) {
    std::vector<double> power(pr->shooterCount(), 0.0);
    uint32_t best = 0;
    for (uint32_t s = 0; s < pr->shooterCount(); ++s) {
      for (uint32_t e = pr->shooterBegin(s); e < pr->shooterEnd(s); ++e) {
        power[s] += residualLuminance(pr->residual(e)) * pr->elementArea(e);
      }
      if (power[s] > power[best]) best = s;
      EXPECT_NEAR(pr->residualPower(s), power[s], 1e-12 * (1.0 + power[s]));
    }
    EXPECT_EQ(pr->selectShooter(), best);
    pr->shoot(best);
  }
  // The ambient term (eq. 4-6) vanishes with the unshot energy and is only for display.
  const glm::dvec3 amb = pr->ambient();
  EXPECT_GT(amb.x, 0.0);
  EXPECT_EQ(pr->displayRadiosity(0), pr->radiosity(0) + pr->reflectance(0) * amb);
}

// Per-mesh area-weighted mean radiosity, keyed by mesh name, from per-scene-triangle values.
std::map<std::string, glm::dvec3> meshMeans(const Scene& scene,
                                            const std::vector<glm::dvec3>& value_area,
                                            const std::vector<double>& area) {
  std::map<std::string, glm::dvec3> out;
  size_t t = 0;
  for (const Mesh& m : scene.meshes) {
    glm::dvec3 sum(0.0);
    double a = 0.0;
    for (size_t k = 0; k < m.triangleCount(); ++k, ++t) {
      sum += value_area[t];
      a += area[t];
    }
    out[m.name] = sum / a;
  }
  return out;
}

// Substructuring (sec. 3) shoots a cluster from one point. After the light's shot the floor's
// clusters along the boxes' bases are half lit and half under a box; from their area centroid,
// under the box, their shadow rays found every box face hidden, and the boxes came out 7% dark
// in the Cornell box (flat scheme, the GPU path's). From the centroid of their power, the
// boxes receive from the floor what the floor's elements shooting one by one give them.
TEST(ProgressiveRadiosity, AHalfShadowedClusterShootsFromItsLitPart) {
  Expected<Scene> cornell = builtinScene("cornell");
  ASSERT_TRUE(cornell.ok());
  ProgressiveOptions o;
  o.atlas.texel_density = 40.0;
  o.shooter_top_points = 0;  // flat
  o.probe_rays = 0;          // the shot's form factors as computed
  o.shooter_level = 0;       // every element a point
  Expected<ProgressiveRadiosity> fine = ProgressiveRadiosity::build(*cornell, o);
  o.shooter_level = 2;  // 4 x 4 texel blocks (10 cm): the boxes' bases cut through many
  Expected<ProgressiveRadiosity> coarse = ProgressiveRadiosity::build(*cornell, o);
  ASSERT_TRUE(fine.ok() && coarse.ok());
  ASSERT_EQ(fine->elementCount(), coarse->elementCount());
  fine->shoot(fine->selectShooter());  // the light
  const ProgressiveState lit = fine->state();
  ASSERT_TRUE(coarse->setState(lit).ok());

  // The floor's shooter: the one whose elements lie at y = 0 with the most residual power.
  uint32_t floor = ProgressiveRadiosity::kNoShooter;
  for (uint32_t s = 0; s < fine->shooterCount(); ++s) {
    if (std::abs(fine->elementPosition(fine->shooterBegin(s)).y) > 1e-6) continue;
    if (floor == ProgressiveRadiosity::kNoShooter ||
        fine->residualPower(s) > fine->residualPower(floor)) {
      floor = s;
    }
  }
  ASSERT_NE(floor, ProgressiveRadiosity::kNoShooter);
  uint32_t dark = 0;  // floor elements under the boxes
  for (uint32_t e = fine->shooterBegin(floor); e < fine->shooterEnd(floor); ++e) {
    dark += fine->residual(e) == glm::dvec3(0.0);
  }
  EXPECT_GT(dark, 20u);
  fine->shoot(floor);
  coarse->shoot(floor);

  // What the boxes' faces received from the floor (the radiosity gained), per box.
  const size_t nt = flattenScene(*cornell).triangles.size();
  std::vector<glm::dvec3> gain_fine(nt, glm::dvec3(0.0)), gain_coarse(nt, glm::dvec3(0.0));
  std::vector<double> area(nt, 0.0);
  const RadiositySurface& surface = fine->surface();
  for (size_t e = 0; e < fine->elementCount(); ++e) {
    const SurfaceFace& f = surface.atlas.faces[surface.atlas.element_face[e]];
    if (f.back) continue;
    const double a = fine->elementArea(e);
    gain_fine[f.triangle] += (fine->radiosity(e) - lit.radiosity[e]) * a;
    gain_coarse[f.triangle] += (coarse->radiosity(e) - lit.radiosity[e]) * a;
    area[f.triangle] += a;
  }
  const auto by_fine = meshMeans(*cornell, gain_fine, area);
  const auto by_coarse = meshMeans(*cornell, gain_coarse, area);
  for (const char* box : {"smallbox", "largebox"}) {
    const double ratio = by_coarse.at(box).y / by_fine.at(box).y;
    std::printf("%s: from the floor's 4 x 4 blocks %.4f of what its elements give\n", box, ratio);
    EXPECT_NEAR(ratio, 1.0, 0.035) << box;
  }
}

// The flat scheme's level fits the average shooter; the Cornell box's light, 13 x 10 texels
// at the default density, had 4 points at the GPU's default level 3 and cast the boxes' shadows
// from them. A shooter keeps at least shooter_min_points points: the light shoots from level 1
// (48 points), and its shot's floor is 1.2% RMS from the light's elements' shot (7.7% from 4).
TEST(ProgressiveRadiosity, ASmallShooterKeepsItsPointsInTheFlatScheme) {
  Expected<Scene> cornell = builtinScene("cornell");
  ASSERT_TRUE(cornell.ok());
  ProgressiveOptions o;
  o.atlas.texel_density = 100.0;
  o.shooter_top_points = 0;
  o.probe_rays = 0;
  o.max_iterations = 1;  // the light's shot
  o.shooter_level = 3;
  Expected<ProgressiveRadiosity> kept = ProgressiveRadiosity::build(*cornell, o);
  o.shooter_min_points = 0;
  Expected<ProgressiveRadiosity> few = ProgressiveRadiosity::build(*cornell, o);
  o.shooter_level = 0;
  Expected<ProgressiveRadiosity> exact = ProgressiveRadiosity::build(*cornell, o);
  ASSERT_TRUE(kept.ok() && few.ok() && exact.ok());
  const uint32_t light = kept->selectShooter();
  ASSERT_NE(kept->emission(kept->shooterBegin(light)), glm::dvec3(0.0));
  EXPECT_EQ(few->flatLevel(light), 3);
  EXPECT_EQ(few->shooterBlocks(light, 3).size(), 4u);
  EXPECT_EQ(kept->flatLevel(light), 1);
  EXPECT_GE(kept->shooterBlocks(light, 1).size(), 16u);
  for (ProgressiveRadiosity* pr : {&*kept, &*few, &*exact}) pr->shoot(light);
  // The floor's irradiance from the light, element by element, against the exact shot.
  double num_kept = 0.0, num_few = 0.0, den = 0.0;
  for (size_t e = 0; e < exact->elementCount(); ++e) {
    if (exact->elementNormal(e).y < 0.99 || exact->elementPosition(e).y > 1e-6) continue;
    const double x = exact->radiosity(e).y, a = exact->elementArea(e);
    num_kept += std::pow(kept->radiosity(e).y - x, 2.0) * a;
    num_few += std::pow(few->radiosity(e).y - x, 2.0) * a;
    den += x * x * a;
  }
  const double rms_kept = std::sqrt(num_kept / den), rms_few = std::sqrt(num_few / den);
  std::printf(
      "the light's shot on the floor against its elements': relative RMS %.4f from 4 "
      "points, %.4f from %zu\n",
      rms_few, rms_kept, kept->shooterBlocks(light, 1).size());
  EXPECT_LT(rms_kept, 0.5 * rms_few);
}

// Flat-scheme checkpoints record the shooters' minimum points since format 4: one written by an
// earlier version is refused by name, not taken for a foreign file.
TEST(ProgressiveCheckpoint, AnEarlierFormatIsRefusedAsSuch) {
  test::TempDir dir;
  const std::string old =
      dir.write("old.checkpoint", std::string("PENUMBRA-PRGRSV3") + std::string(300, '\0'));
  Expected<ProgressiveCheckpointInfo> info = readProgressiveCheckpointInfo(old);
  ASSERT_FALSE(info.ok());
  EXPECT_NE(info.error().describe().find("earlier version of Penumbra (checkpoint format 3)"),
            std::string::npos)
      << info.error().describe();
  const std::string other = dir.write("other.checkpoint", std::string(300, 'x'));
  Expected<ProgressiveCheckpointInfo> none = readProgressiveCheckpointInfo(other);
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.error().describe().find("not a Penumbra progressive radiosity checkpoint"),
            std::string::npos);
}

TEST(ProgressiveRadiosity, CornellWallsAgreeWithTheMatrixMethod) {
  Expected<Scene> cornell = builtinScene("cornell");
  ASSERT_TRUE(cornell.ok());
  const size_t nt = flattenScene(*cornell).triangles.size();

  MatrixRadiosityOptions mo;
  mo.elements = 1500;
  Expected<MatrixRadiosity> mr = buildMatrixRadiosity(*cornell, mo);
  ASSERT_TRUE(mr.ok()) << mr.error().describe();
  SolveOptions so;
  so.tolerance = 1e-10;
  ASSERT_TRUE(mr->solve(so).converged);
  std::vector<glm::dvec3> m_sum(nt, glm::dvec3(0.0));
  std::vector<double> m_area(nt, 0.0);
  const std::vector<glm::dvec3> mb = mr->elementRadiosity();
  for (size_t e = 0; e < mb.size(); ++e) {
    const SurfaceFace& f = mr->surface.atlas.faces[mr->surface.atlas.element_face[e]];
    if (f.back) continue;
    const double a = mr->surface.atlas.element_area[e];
    m_sum[f.triangle] += mb[e] * a;
    m_area[f.triangle] += a;
  }

  ProgressiveOptions o;
  o.atlas.texel_density = 40.0;
  o.shooter_level = 1;
  o.convergence = 1e-3;
  o.max_iterations = 3000;
  Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(*cornell, o);
  ASSERT_TRUE(pr.ok()) << pr.error().describe();
  const ProgressiveStats st = pr->solve();
  // Per scene triangle, over the front faces' elements (the walls' outer sides see no light).
  std::vector<glm::dvec3> p_sum(nt, glm::dvec3(0.0));
  std::vector<double> p_area(nt, 0.0);
  for (size_t e = 0; e < pr->elementCount(); ++e) {
    const SurfaceFace& f = pr->atlas().faces[pr->atlas().element_face[e]];
    if (f.back) continue;
    p_sum[f.triangle] += pr->radiosity(e) * pr->elementArea(e);
    p_area[f.triangle] += pr->elementArea(e);
  }
  std::printf(
      "cornell progressive: %zu elements (matrix %zu), %d iterations, unshot %.4f, %.2f s "
      "(%.1f ms/iteration), %llu rays\n",
      pr->elementCount(), mr->size(), st.iterations, st.unshot_fraction, st.seconds,
      1e3 * st.seconds / std::max(1, st.iterations), static_cast<unsigned long long>(st.rays));

  const auto pm = meshMeans(*cornell, p_sum, p_area);
  const auto mm = meshMeans(*cornell, m_sum, m_area);
  for (const char* wall : {"floor", "ceiling", "back", "redwall", "greenwall"}) {
    const glm::dvec3 p = pm.at(wall), m = mm.at(wall);
    // Luminance and the wall's dominant channel.
    const double dl = residualLuminance(p) / residualLuminance(m) - 1.0;
    double worst = 0.0;
    for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(p[c] / m[c] - 1.0));
    std::printf(
        "  %-9s progressive (%.4f %.4f %.4f) matrix (%.4f %.4f %.4f): luminance %+.4f, "
        "worst channel %.4f\n",
        wall, p.x, p.y, p.z, m.x, m.y, m.z, dl, worst);
    // Measured 0.8-1.9% (ceiling 1.9%; the two methods discretise differently: 6,979 texels
    // against 1,500 matrix clusters interpolated to their own lightmap).
    EXPECT_LE(worst, 0.035) << wall;
  }
}

// Sec. 3.1: bilinear lookups must never read unlit texels. In the furnace every element's
// radiance is B / pi = 2, so any texel a lookup can touch that was left unfilled (0) or filled
// from another triangle's chart shows up. The lookup points cover each triangle densely,
// including its edges and corners, where the footprint reaches past the chart's own texels.
TEST(ProgressiveRadiosity, BilinearLookupsReadOnlyFilledTexelsOfTheirOwnChart) {
  Expected<Scene> furnace = builtinScene("furnace");
  ASSERT_TRUE(furnace.ok());
  ProgressiveOptions o;
  o.atlas.texel_density = 5.0;
  o.convergence = 1e-4;
  Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(*furnace, o);
  ASSERT_TRUE(pr.ok()) << pr.error().describe();
  ASSERT_TRUE(pr->solve().converged);
  const Image lightmap = pr->radianceImage();
  const ChartAtlas& a = pr->atlas();
  const double exact = 2.0;
  constexpr int kSteps = 40;
  size_t lookups = 0, touched_border = 0, wrong_triangle = 0, unlit = 0;
  double worst = 0.0;
  for (uint32_t t = 0; t < a.faces.size(); ++t) {
    if (a.charts.face_chart[t] < 0 || a.faces[t].back) continue;  // the inside of the furnace
    for (int i = 0; i <= kSteps; ++i) {
      for (int j = 0; i + j <= kSteps; ++j) {
        const glm::vec2 bary(float(i) / kSteps, float(j) / kSteps);
        const glm::vec2 uv = (1.0f - bary.x - bary.y) * a.uvs[3 * t] + bary.x * a.uvs[3 * t + 1] +
                             bary.y * a.uvs[3 * t + 2];
        // The texels bilinear filtering reads (GL_LINEAR): the 2 x 2 block around the sample
        // point in texel-centre coordinates, with their weights.
        const double px = double(uv.x) * a.width - 0.5, py = double(uv.y) * a.height - 0.5;
        const int x0 = int(std::floor(px)), y0 = int(std::floor(py));
        const double fx = px - x0, fy = py - y0;
        for (int dy = 0; dy <= 1; ++dy) {
          for (int dx = 0; dx <= 1; ++dx) {
            const double w = (dx ? fx : 1.0 - fx) * (dy ? fy : 1.0 - fy);
            // GPUs resolve the weights to 8 fractional bits: a texel weighted below 1/512
            // (float rounding of a UV on a chart's leg) contributes nothing.
            if (w < 1.0 / 512.0) continue;
            const int x = std::clamp(x0 + dx, 0, a.width - 1),
                      y = std::clamp(y0 + dy, 0, a.height - 1);
            const size_t k = a.texelIndex(x, y);
            if (a.texel_chart[k] != a.charts.face_chart[t]) ++wrong_triangle;
            if (a.texel_kind[k] != AtlasTexelKind::kInside) ++touched_border;
            const glm::vec3 v = lightmap.pixels[k];
            if (!(v.x > 0.0f && v.y > 0.0f && v.z > 0.0f)) ++unlit;
            worst = std::max(worst, std::abs(double(v.x) - exact) / exact);
          }
        }
        ++lookups;
        const glm::vec3 v = sampleBilinear(lightmap, uv);
        worst = std::max(worst, std::abs(double(v.x) - exact) / exact);
      }
    }
  }
  std::printf(
      "furnace lightmap %dx%d: %zu lookups, %zu texel reads outside the charts' elements, "
      "%zu of another chart, %zu unlit; worst radiance error %.4f\n",
      a.width, a.height, lookups, touched_border, wrong_triangle, unlit, worst);
  EXPECT_GT(touched_border, 0u);  // the lookups do reach the border rows
  EXPECT_EQ(wrong_triangle, 0u);
  EXPECT_EQ(unlit, 0u);
  EXPECT_LE(worst, 0.01);
}

// A 16-sided prism standing in for a cylinder of radius 0.5 m, lit by a small emitter 10 m
// away. With shading normals (Wallner sec. 3 interpolates normals) the direct irradiance of
// every element follows the smooth cylinder's cosine; with each triangle's own normal it
// follows the facets' (up to 11.25 degrees off), which is what makes a tessellated surface look
// faceted.
Scene cylinderScene() {
  Scene s;
  s.source = "test:cylinder";
  s.materials = {{"grey", glm::vec3(0.5f), glm::vec3(0.0f)},
                 {"light", glm::vec3(0.0f), glm::vec3(10.0f)}};
  Mesh cylinder;
  constexpr int kSides = 16;
  for (int i = 0; i < kSides; ++i) {
    const float a = 2.0f * float(kPi) * float(i) / kSides;
    cylinder.positions.emplace_back(0.5f * std::cos(a), 0.5f * std::sin(a), 0.0f);
    cylinder.positions.emplace_back(0.5f * std::cos(a), 0.5f * std::sin(a), 1.0f);
  }
  for (uint32_t i = 0; i < kSides; ++i) {
    const uint32_t j = (i + 1) % kSides;
    // Counter-clockwise seen from outside.
    cylinder.triangles.emplace_back(2 * i, 2 * j, 2 * j + 1);
    cylinder.triangles.emplace_back(2 * i, 2 * j + 1, 2 * i + 1);
  }
  cylinder.material_ids.assign(cylinder.triangles.size(), 0);
  s.meshes.push_back(cylinder);
  Mesh light;
  light.positions = {
      {10.0f, -0.1f, 0.4f}, {10.0f, -0.1f, 0.6f}, {10.0f, 0.1f, 0.6f}, {10.0f, 0.1f, 0.4f}};
  light.triangles = {{0, 1, 2}, {0, 2, 3}};  // facing -x, towards the cylinder
  light.material_ids = {1, 1};
  s.meshes.push_back(light);
  return s;
}

TEST(ProgressiveRadiosity, ShadingNormalsFollowTheSmoothSurface) {
  Scene scene = cylinderScene();
  ASSERT_TRUE(validateScene(scene).ok());
  double worst[2] = {0.0, 0.0};
  for (int shading = 0; shading < 2; ++shading) {
    ProgressiveOptions o;
    o.atlas.texel_density = 40.0;
    o.shading_normals = shading == 1;
    Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(scene, o);
    ASSERT_TRUE(pr.ok()) << pr.error().describe();
    {  // the emitter's chart (its two triangles) shoots first
      const uint32_t light = pr->selectShooter();
      ASSERT_LT(light, pr->shooterCount());
      ASSERT_NE(pr->emission(pr->shooterBegin(light)), glm::dvec3(0.0));
      pr->shoot(light);
    }
    // A small Lambertian emitter: E = L A cos_l cos_r / d^2.
    const glm::dvec3 centre(10.0, 0.0, 0.5);
    const double power = 10.0 * 0.04;  // L A
    size_t compared = 0;
    for (size_t e = 0; e < pr->elementCount(); ++e) {
      const SurfaceFace& f = elementFace(*pr, e);
      if (f.triangle >= 32 || f.back) continue;  // the cylinder's outside
      const glm::dvec3 p = pr->elementPosition(e);
      const glm::dvec3 n = glm::normalize(glm::dvec3(p.x, p.y, 0.0));  // the smooth surface's
      const glm::dvec3 d = centre - p;
      const double dist = glm::length(d);
      const double cos_r = glm::dot(n, d) / dist, cos_l = d.x / dist;
      if (cos_r < 0.3) continue;  // away from the terminator, where facets and cylinder part
      const double expect = power * cos_l * cos_r / (dist * dist);
      const double got = pr->radiosity(e).x / 0.5;  // E = gain / rho
      worst[shading] = std::max(worst[shading], std::abs(got / expect - 1.0));
      ++compared;
    }
    EXPECT_GT(compared, 500u);
  }
  std::printf(
      "cylinder: worst irradiance error against the smooth cylinder: triangle normals "
      "%.3f, shading normals %.4f\n",
      worst[0], worst[1]);
  EXPECT_GT(worst[0], 0.1);   // the facets' own cosine
  EXPECT_LT(worst[1], 0.03);  // the smooth surface's
}

}  // namespace
}  // namespace penumbra
