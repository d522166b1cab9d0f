// The three passes of the subsurface method (Carr, Hall, Hart 2003, sec. 4.2) end to end: a
// large slab under a directional light shows the dipole's closed-form radiance, pass 1 follows
// the Fresnel-weighted cosine law as the light moves, and `render --method sss` writes a light
// orbit with its per-pass times.
#include "penumbra/subsurface/sss.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/kernels/dipole.h"
#include "penumbra/render/sss_view.h"
#include "penumbra/scene/media.h"
#include "support/test_util.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/vec4.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>

namespace penumbra {
namespace {

Scene slabScene(const char* preset) {
  // A 20 x 20 mm slab, 4 mm thick, faces wound outwards, top at y = 4 mm.
  Scene s;
  s.source = "slab";
  const Mesh m = test::boxMesh(0.02, 0.004, 0.02);
  s.meshes.push_back(m);
  Material mat;
  mat.name = preset;
  mat.subsurface = subsurfacePreset(preset);
  s.materials.push_back(mat);
  return s;
}

TEST(Sss, SlabUnderADirectionalLightShowsTheDipolesClosedForm) {
  // Irradiance E0 straight down: E = F_t(eta, 1) E0 enters (eq. 8), B = R_d E leaves the plane
  // far from its edges (eq. 7 over the plane), and seen straight on L = F_t(eta, 1) B / pi
  // (eq. 6).
  // Jensen's skin1 three times as dense: diffusion lengths 1.2, 0.5 and 0.2 mm, so 7 mm from the
  // edges the slab is the infinite plane of the closed form to 1e-4.
  Scene scene = slabScene("skin1");
  scene.materials[0].subsurface->sigma_s_prime *= 3.0;
  scene.materials[0].subsurface->sigma_a *= 3.0;
  const float e0 = 3.0f;
  scene.lights.push_back(DirectionalLight{glm::vec3(0, -1, 0), glm::vec3(e0)});
  SssOptions o;
  o.resolution = LightmapResolution{4000.0, std::nullopt};
  o.links.links = 32;
  Expected<SssSolver> solver = SssSolver::build(scene, o);
  ASSERT_TRUE(solver.ok()) << solver.error().describe();
  const std::vector<glm::vec3> e = solver->transmittedIrradiance(scene.lights);
  const std::vector<glm::vec3> b = solver->scatter(e);
  const Image atlas = solver->scatteredRadianceAtlas(b);
  Camera cam;
  cam.position = glm::vec3(0.01f, 0.5f, 0.01f);
  cam.look_at = glm::vec3(0.01f, 0.0f, 0.01f);
  cam.up = glm::vec3(0, 0, 1);
  cam.vertical_fov = 0.01f;  // 5 mm across at the slab: its centre only
  SssViewSettings vs;
  vs.width = vs.height = 8;
  vs.spp = 4;
  const SssView view = SssView::trace(*solver, cam, vs);
  EXPECT_EQ(view.translucentSamples(), 8u * 8u * 4u);
  const Image image = view.render(*solver, atlas, scene.lights);
  const Subsurface& m = *scene.materials[0].subsurface;
  const glm::dvec3 rd = Dipole(m.sigma_s_prime, m.sigma_a, m.eta).totalReflectance();
  const double ft = fresnelTransmittance(m.eta, 1.0);
  for (int c = 0; c < 3; ++c) {
    double mean = 0.0;
    for (const glm::vec3& px : image.pixels) mean += px[c] / double(image.pixels.size());
    const double expected = ft * ft * rd[c] * e0 / std::numbers::pi;
    EXPECT_NEAR(mean / expected, 1.0, 0.02) << "channel " << c;
  }
}

TEST(Sss, TransmittedIrradianceFollowsTheFresnelWeightedCosineLaw) {
  Scene scene = slabScene("marble");
  SssOptions o;
  o.resolution = LightmapResolution{500.0, std::nullopt};
  o.links.links = 4;
  Expected<SssSolver> solver = SssSolver::build(scene, o);
  ASSERT_TRUE(solver.ok()) << solver.error().describe();
  size_t top = 0;
  for (size_t i = 0; i < solver->surface().elementCount(); ++i) {
    if (solver->surface().atlas.element_normal[i].y > 0.99) top = i;
  }
  for (double deg : {0.0, 30.0, 60.0, 80.0}) {
    const double a = deg * std::numbers::pi / 180.0;
    const std::vector<Light> lights = {DirectionalLight{
        glm::vec3(float(std::sin(a)), float(-std::cos(a)), 0.0f), glm::vec3(2.0f)}};
    const std::vector<glm::vec3> e = solver->transmittedIrradiance(lights);
    const double expected = 2.0 * std::cos(a) * fresnelTransmittance(1.3, std::cos(a));
    EXPECT_NEAR(e[top].x, expected, 1e-5 * 2.0) << deg << " degrees";
  }
  // The bottom face turns away from the light and gets nothing.
  const std::vector<Light> down = {DirectionalLight{glm::vec3(0, -1, 0), glm::vec3(1.0f)}};
  const std::vector<glm::vec3> e = solver->transmittedIrradiance(down);
  for (size_t i = 0; i < e.size(); ++i) {
    if (solver->surface().atlas.element_normal[i].y < -0.99) {
      ASSERT_EQ(e[i], glm::vec3(0.0f));
    }
  }
}

TEST(Sss, LinksAreCachedAndADamagedCacheIsRebuilt) {
  test::TempDir dir;
  Scene scene = slabScene("marble");
  SssOptions o;
  o.resolution = LightmapResolution{400.0, std::nullopt};
  o.links.links = 8;
  o.cache_directory = (dir.path() / "cache").string();
  Expected<SssSolver> first = SssSolver::build(scene, o);
  ASSERT_TRUE(first.ok()) << first.error().describe();
  EXPECT_FALSE(first->linksFromCache());
  EXPECT_TRUE(first->cacheProblem().empty()) << first->cacheProblem();
  Expected<SssSolver> second = SssSolver::build(scene, o);
  ASSERT_TRUE(second.ok());
  EXPECT_TRUE(second->linksFromCache());
  EXPECT_EQ(second->links().node, first->links().node);
  EXPECT_EQ(second->links().factor, first->links().factor);
  EXPECT_EQ(second->links().offset, first->links().offset);
  // Other options, another fingerprint.
  o.links.links = 9;
  Expected<SssSolver> other = SssSolver::build(scene, o);
  ASSERT_TRUE(other.ok());
  EXPECT_FALSE(other->linksFromCache());
  // A damaged file is ignored and written again.
  o.links.links = 8;
  for (const auto& f : std::filesystem::directory_iterator(o.cache_directory)) {
    std::filesystem::resize_file(f.path(), std::filesystem::file_size(f.path()) - 7);
  }
  Expected<SssSolver> rebuilt = SssSolver::build(scene, o);
  ASSERT_TRUE(rebuilt.ok());
  EXPECT_FALSE(rebuilt->linksFromCache());
  EXPECT_EQ(rebuilt->links().factor, first->links().factor);
  Expected<SssSolver> again = SssSolver::build(scene, o);
  ASSERT_TRUE(again.ok());
  EXPECT_TRUE(again->linksFromCache());
}

TEST(Sss, SceneWithoutTranslucentMaterialsIsRefused) {
  Scene scene = slabScene("marble");
  scene.materials[0].subsurface.reset();
  Expected<SssSolver> solver = SssSolver::build(scene, SssOptions{});
  ASSERT_FALSE(solver.ok());
  EXPECT_NE(solver.error().message.find("no material has a subsurface block"), std::string::npos);
}

TEST(Sss, RenderWritesALightOrbitWithPerPassTimes) {
  test::TempDir dir;
  const std::string out = (dir.path() / "orbit" / "bunny.png").string();
  const std::string stats = (dir.path() / "s.json").string();
  const std::string env = "PENUMBRA_CACHE_DIR=" + (dir.path() / "cache").string();
  const std::string args =
      "render sss --method sss --lightmap-size 128 --links 8 --width 48 --height 48 --spp 1 "
      "--frames 3 -o " +
      out + " --stats " + stats;
  const test::CliResult r = test::runCli(args, env);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (int f = 0; f < 3; ++f) {
    EXPECT_TRUE(std::filesystem::exists(dir.path() / "orbit" / fmt::format("bunny_{:04d}.png", f)));
  }
  std::ifstream in(stats);
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["method"], "sss");
  EXPECT_EQ(j["links"], 8);
  ASSERT_EQ(j["frames"].size(), 3u);
  for (const auto& f : j["frames"]) {
    EXPECT_GT(f["pass1_seconds"].get<double>(), 0.0);
    EXPECT_GT(f["pass2_seconds"].get<double>(), 0.0);
    EXPECT_GT(f["pass3_seconds"].get<double>(), 0.0);
  }
  EXPECT_GT(j["elements"].get<int>(), 1000);
  EXPECT_FALSE(j["links_cached"].get<bool>());
  // The second run reads the links back.
  ASSERT_EQ(test::runCli(args, env).exit_code, 0);
  std::ifstream again(stats);
  EXPECT_TRUE(nlohmann::json::parse(again)["links_cached"].get<bool>());
  // Options of other methods are refused, and so is a scene with nothing translucent.
  EXPECT_EQ(test::runCli("render sss --method sss --solver jacobi").exit_code, 2);
  EXPECT_EQ(
      test::runCli("render cornell --method sss -o " + (dir.path() / "c.png").string()).exit_code,
      2);
  EXPECT_EQ(test::runCli("render cornell --links 4").exit_code, 2);
}

}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {

TEST(Sss, WithoutShadowsPassOneOnlyGains) {
  // --no-shadows (the paper's pass 1): no element loses light, and those in shadow gain it.
  const Expected<Scene> scene = loadScene("sss");
  ASSERT_TRUE(scene.ok());
  SssOptions o;
  o.resolution = LightmapResolution{std::nullopt, 96};
  o.links.links = 2;
  Expected<SssSolver> with = SssSolver::build(*scene, o);
  o.shadows = false;
  Expected<SssSolver> without = SssSolver::build(*scene, o);
  ASSERT_TRUE(with.ok() && without.ok());
  EXPECT_FALSE(without->shadows());
  const std::vector<glm::vec3> e1 = with->transmittedIrradiance(scene->lights);
  const std::vector<glm::vec3> e0 = without->transmittedIrradiance(scene->lights);
  ASSERT_EQ(e0.size(), e1.size());
  size_t gained = 0;
  for (size_t i = 0; i < e0.size(); ++i) {
    ASSERT_GE(e0[i].x, e1[i].x);
    gained += e0[i].x > e1[i].x ? 1 : 0;
  }
  EXPECT_GT(gained, e0.size() / 20);
}

}  // namespace
}  // namespace penumbra
