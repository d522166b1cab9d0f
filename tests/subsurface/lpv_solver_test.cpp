// SSLPV (Børlum et al. 2011) end to end on the CPU: the reflective shadow maps inject exactly the
// flux the boundary transmits; against the dipole (the sss method's model, the closed form on a
// slab and the method on the bunny) the volumes' exitant radiance is measured and stated (the
// paper claims plausibility, not agreement: docs/algorithms.md gives the figures).
#include "penumbra/io/scene_io.h"
#include "penumbra/kernels/dipole.h"
#include "penumbra/render/sss_frames.h"
#include "penumbra/scene/media.h"
#include "penumbra/subsurface/lpv.h"
#include "penumbra/subsurface/sss.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <cmath>
#include <cstdio>
#include <numbers>

namespace penumbra {
namespace {

// A 20 x 20 mm slab of marble, `thickness` mm thick, top at y = thickness, under a directional
// light straight down.
Scene marbleSlab(double thickness_mm, float e0) {
  Scene s;
  s.source = "slab";
  s.meshes.push_back(test::boxMesh(0.02, thickness_mm * 1e-3, 0.02));
  Material m;
  m.name = "marble";
  m.subsurface = subsurfacePreset("marble");
  m.two_sided = false;
  s.materials.push_back(m);
  s.lights.push_back(DirectionalLight{glm::vec3(0, -1, 0), glm::vec3(e0)});
  EXPECT_TRUE(validateScene(s).ok());
  return s;
}

// Injection (sec. 3.1): the orthographic map of a directional light over the slab's top puts
// F_t(eta, 1) E A into the boundary cells, the flux the boundary transmits.
TEST(LpvSolver, InjectionCarriesTheTransmittedFlux) {
  const float e0 = 2.0f;
  const Scene scene = marbleSlab(4.0, e0);
  LpvOptions o;
  o.rsm_resolution = 512;
  Expected<LpvSolver> solver = LpvSolver::build(scene, o);
  ASSERT_TRUE(solver.ok()) << solver.error().describe();
  Expected<LpvFrameTimes> updated = solver->update(scene);
  ASSERT_TRUE(updated.ok());
  const LpvFrameTimes t = *updated;
  EXPECT_GT(t.rsm_texels, 100000u);
  const glm::dvec3 flux = solver->objects()[0].injected.flux();
  const double want = fresnelTransmittance(1.3, 1.0) * e0 * 0.02 * 0.02;
  std::printf("injected %.6e W (F_t E A = %.6e W), %llu texels\n", flux.x, want,
              static_cast<unsigned long long>(t.rsm_texels));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(flux[c] / want, 1.0, 0.01) << c;
}

// Emitters and the environment (subsurface/lpv_inject.cpp): a closed box of marble under a
// uniform sky of radiance L takes in pi L A (1 - F_dr,ext(eta)) through its whole surface A; the
// gathered surface points inject that flux (a Monte Carlo estimate: within 1%), and a sky twice
// as bright (the surroundings changed, the geometry did not) injects twice as much.
TEST(LpvSolver, TheEnvironmentInjectsTheTransmittedFlux) {
  Scene scene = marbleSlab(4.0, 0.0f);
  scene.lights.clear();
  scene.environment = glm::vec3(0.5f);
  Expected<LpvSolver> solver = LpvSolver::build(scene, LpvOptions{});
  ASSERT_TRUE(solver.ok());
  ASSERT_TRUE(solver->update(scene).ok());
  const double area = 2.0 * (0.02 * 0.02 + 2.0 * 0.02 * 0.004);
  const double want =
      std::numbers::pi * 0.5 * area * (1.0 - externalDiffuseFresnelReflectance(1.3));
  const glm::dvec3 flux = solver->objects()[0].injected.flux();
  std::printf("sky: injected %.6e W, pi L A (1 - F_dr,ext) = %.6e W\n", flux.x, want);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(flux[c] / want, 1.0, 0.01) << c;
  scene.environment = glm::vec3(1.0f);
  ASSERT_TRUE(solver->update(scene).ok());
  const glm::dvec3 twice = solver->objects()[0].injected.flux();
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(twice[c] / flux[c], 2.0, 1e-4) << c;
}

// The slab's top seen straight on, 5 mm across its centre, against the dipole's closed form
// F_t(eta, 1)^2 R_d E / pi (Jensen et al. 2001; the sss method meets it to 2%), and the bunny of
// the built-in `lpv` scene against the sss method on the same scene: mean radiance over the
// bunny's pixels. Measured at the defaults (32 cells, 8 steps, the first 2 left out): the bars
// only say that the volumes give the dipole's order of magnitude.
TEST(LpvSolver, ExitantRadianceAgainstTheDipole) {
  const float e0 = 3.0f;
  const Scene slab = marbleSlab(4.0, e0);
  Expected<LpvSolver> solver = LpvSolver::build(slab, LpvOptions{});
  ASSERT_TRUE(solver.ok());
  ASSERT_TRUE(solver->update(slab).ok());
  Camera cam;
  cam.position = glm::vec3(0.01f, 0.5f, 0.01f);
  cam.look_at = glm::vec3(0.01f, 0.0f, 0.01f);
  cam.up = glm::vec3(0, 0, 1);
  cam.vertical_fov = 0.01f;
  const Image top = solver->render(slab, cam, 8, 8, 4, 0);
  const Subsurface& m = *slab.materials[0].subsurface;
  const glm::dvec3 rd = Dipole(m.sigma_s_prime, m.sigma_a, m.eta).totalReflectance();
  const double ft = fresnelTransmittance(m.eta, 1.0);
  for (int c = 0; c < 3; ++c) {
    double mean = 0.0;
    for (const glm::vec3& px : top.pixels) mean += px[c] / double(top.pixels.size());
    const double dipole = ft * ft * rd[c] * e0 / std::numbers::pi;
    std::printf("slab, channel %d: SSLPV %.4f, dipole %.4f W m^-2 sr^-1: ratio %.3f\n", c, mean,
                dipole, mean / dipole);
    EXPECT_GT(mean / dipole, 0.25) << c;
    EXPECT_LT(mean / dipole, 4.0) << c;
  }

  Expected<Scene> bunny = loadScene("lpv");
  ASSERT_TRUE(bunny.ok());
  Expected<LpvSolver> lpv = LpvSolver::build(*bunny, LpvOptions{});
  ASSERT_TRUE(lpv.ok());
  ASSERT_TRUE(lpv->update(*bunny).ok());
  const int w = 96, h = 96;
  const Image lpv_image = lpv->render(*bunny, *bunny->camera, w, h, 4, 0);
  SssOptions so;
  so.resolution = LightmapResolution{std::nullopt, 256};
  so.links.links = 16;
  Expected<SssSolver> sss = SssSolver::build(*bunny, so);
  ASSERT_TRUE(sss.ok());
  SssViewSettings vs;
  vs.width = w;
  vs.height = h;
  vs.spp = 4;
  Expected<SssFrames> frames = SssFrames::create(*sss, *bunny->camera, vs, false);
  ASSERT_TRUE(frames.ok());
  Expected<SssFrame> frame = frames->render(bunny->lights, nullptr);
  ASSERT_TRUE(frame.ok());
  glm::dvec3 a(0.0), b(0.0);
  for (size_t i = 0; i < lpv_image.pixels.size(); ++i) {
    a += glm::dvec3(lpv_image.pixels[i]);
    b += glm::dvec3(frame->image.pixels[i]);
  }
  for (int c = 0; c < 3; ++c) {
    std::printf("bunny, channel %d: SSLPV / dipole mean radiance %.3f\n", c, a[c] / b[c]);
    EXPECT_GT(a[c] / b[c], 0.125) << c;
    EXPECT_LT(a[c] / b[c], 8.0) << c;
  }
}

}  // namespace
}  // namespace penumbra
