// Textures and cut-outs in the ray-traced methods against closed forms: the chequered furnace
// (the mean albedo sets the light, the texture at each pixel its share), a half-masked occluder
// that lets half the sun through (the Ray Engine's cut-out test, the path tracer, Whitted), a
// partly covering one, and an emissive texture whose flux is its mean times its area.
#include "penumbra/kernels/form_factor.h"
#include "penumbra/raytrace/camera_rays.h"
#include "penumbra/raytrace/cutout_filter.h"
#include "penumbra/raytrace/path_tracer.h"
#include "penumbra/raytrace/ray_queries.h"
#include "penumbra/raytrace/scene_geometry.h"
#include "penumbra/raytrace/whitted.h"
#include "support/textured_scenes.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

namespace penumbra {
namespace {

// What every pixel of the chequered furnace shows: Le + rho(x) Le / (1 - rho_mean), with rho(x)
// averaged over the pixel (16 stratified rays through it).
Image expectedFurnaceImage(const Scene& s, const Camera& camera, int size, double rho_mean) {
  const SceneGeometry g = SceneGeometry::build(s);
  const CameraRays rays(camera, size, size);
  Image out(size, size);
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      double rho = 0.0;
      for (int k = 0; k < 16; ++k) {
        const Ray r = rays.ray(float(x) + (float(k % 4) + 0.5f) / 4.0f,
                               float(y) + (float(k / 4) + 0.5f) / 4.0f);
        const Hit h = g.engine.intersect(r);
        rho += g.reflectanceAt(uint32_t(h.triangle), h.u, h.v).x / 16.0;
      }
      out.at(x, y) = glm::vec3(float(1.0 + rho / (1.0 - rho_mean)));
    }
  }
  return out;
}

TEST(TextureTransport, ChequeredFurnaceFollowsTheMeanAlbedo) {
  const Scene s = test::chequeredFurnace(100, 200);
  const double rho_mean = s.materials[0].reflectance_texture->texture->mean().x;
  EXPECT_NEAR(rho_mean, 0.5 * (srgb8ToLinear(100) + srgb8ToLinear(200)), 1e-6);
  constexpr int kSize = 32;
  const Image expected = expectedFurnaceImage(s, *s.camera, kSize, rho_mean);
  const PathTracer pt(s);
  PathTracerSettings settings;
  settings.width = settings.height = kSize;
  settings.spp = 256;
  const Image img = pt.render(*s.camera, settings);
  double got = 0.0, want = 0.0, worst_block = 0.0;
  for (size_t i = 0; i < img.pixels.size(); ++i) {
    got += img.pixels[i].x;
    want += expected.pixels[i].x;
  }
  // 4 x 4-pixel blocks: the texture's pattern is there, not its mean.
  for (int by = 0; by < kSize; by += 4) {
    for (int bx = 0; bx < kSize; bx += 4) {
      double a = 0.0, b = 0.0;
      for (int y = by; y < by + 4; ++y) {
        for (int x = bx; x < bx + 4; ++x) {
          a += img.at(x, y).x;
          b += expected.at(x, y).x;
        }
      }
      worst_block = std::max(worst_block, std::abs(a / b - 1.0));
    }
  }
  std::printf("chequered furnace: path tracer mean %.4f, closed form %.4f; worst 4x4 block %.4f\n",
              got / img.pixels.size(), want / img.pixels.size(), worst_block);
  EXPECT_NEAR(got / want, 1.0, 0.01);
  EXPECT_LT(worst_block, 0.05);
}

TEST(TextureTransport, HalfMaskedQuadCastsHalfTheShadow) {
  const Scene s = test::floorUnderOccluder(test::maskedLattice(AlphaMode::kMask), 2.0f);
  const SceneGeometry g = SceneGeometry::build(s);
  ASSERT_NE(g.engine.hitFilter(), nullptr);
  // Vertical rays up from a grid under the occluder: half of them pass (every cell is 1/4 m,
  // the grid 1/64 m).
  int passed = 0, total = 0;
  for (int i = 0; i < 128; ++i) {
    for (int k = 0; k < 128; ++k) {
      const Ray up{glm::vec3(-1.0f + (i + 0.5f) / 64.0f, 1e-3f, -1.0f + (k + 0.5f) / 64.0f), 0.0f,
                   glm::vec3(0, 1, 0), 10.0f};
      passed += g.engine.occluded(up) ? 0 : 1;
      ++total;
      // Closest hits agree with occlusion.
      EXPECT_EQ(g.engine.intersect(up).hit(), g.engine.occluded(up));
    }
  }
  EXPECT_EQ(2 * passed, total);
  // The path tracer and Whitted: floor radiance rho E vis / pi, averaged over points under the
  // occluder = 0.5 * 2 * 0.5 / pi.
  const PathTracer pt(s);
  Rng rng(3, 4);
  PathTracerSettings settings;
  uint64_t rays = 0;
  double sum = 0.0;
  // Jittered 64 x 64 points over the whole 8 x 8 cells under the occluder.
  constexpr int kGrid = 64;
  for (int i = 0; i < kGrid; ++i) {
    for (int k = 0; k < kGrid; ++k) {
      const glm::vec3 x(-1.0f + 2.0f * (i + rng.uniform()) / kGrid, 0.0f,
                        -1.0f + 2.0f * (k + rng.uniform()) / kGrid);
      const glm::vec3 eye = x + glm::vec3(0.1f, 0.5f, 0.0f);
      sum += pt.radiance(Ray{eye, 0.0f, glm::normalize(x - eye), 1e30f}, rng, settings, rays).x;
    }
  }
  const int kPoints = kGrid * kGrid;
  const double expected = 0.5 * 2.0 * 0.5 / std::numbers::pi;
  EXPECT_NEAR(sum / kPoints, expected, 0.03 * expected);
  // Whitted (one shadow ray per vertex to the sun): the image of the floor from under the
  // occluder shows the lattice's shadow pixel by pixel as the Ray Engine's occlusion gives it.
  Camera camera;
  camera.position = glm::vec3(0.0f, 0.5f, 0.0f);
  camera.look_at = glm::vec3(0.0f, 0.0f, 0.0f);
  camera.up = glm::vec3(0.0f, 0.0f, 1.0f);
  camera.vertical_fov = 1.2f;
  WhittedSettings ws;
  ws.width = ws.height = 32;
  ws.spp = 1;
  const WhittedTracer whitted(s);
  CpuRayQueries queries(whitted.geometry().engine);
  Expected<Image> img = whitted.render(camera, ws, queries);
  ASSERT_TRUE(img.ok()) << img.error().describe();
  const CameraRays view(camera, ws.width, ws.height);
  int lit = 0, dark = 0;
  for (int y = 0; y < ws.height; ++y) {
    for (int x = 0; x < ws.width; ++x) {
      // Pixels whose corners and centre all agree (away from the cells' edges): the jittered
      // ray's answer is theirs.
      auto shadowedAt = [&](float fx, float fy) {
        const Hit h = g.engine.intersect(view.ray(fx, fy));
        const glm::vec3 p = g.point(uint32_t(h.triangle), h.u, h.v);
        return g.engine.occluded(Ray{p + glm::vec3(0, 1e-3f, 0), 0.0f, glm::vec3(0, 1, 0), 10.0f});
      };
      const bool shadowed = shadowedAt(float(x) + 0.5f, float(y) + 0.5f);
      bool uniform = true;
      for (int c = 0; c < 4; ++c) {
        uniform = uniform && shadowedAt(float(x + (c & 1)), float(y + (c >> 1))) == shadowed;
      }
      if (!uniform) continue;
      const float want = shadowed ? 0.0f : float(0.5 * 2.0 / std::numbers::pi);
      EXPECT_NEAR(img->at(x, y).x, want, 1e-4f) << x << ", " << y;
      (shadowed ? dark : lit) += 1;
    }
  }
  EXPECT_GT(lit, 150);
  EXPECT_GT(dark, 150);
}

TEST(TextureTransport, PartlyCoveringSurfaceLetsOneMinusAlphaThrough) {
  Material veil;
  veil.name = "veil";
  veil.reflectance = glm::vec3(0.0f);
  veil.alpha = 0.25f;
  veil.alpha_mode = AlphaMode::kBlend;
  const Scene s = test::floorUnderOccluder(veil, 2.0f);
  const SceneGeometry g = SceneGeometry::build(s);
  Rng rng(5, 6);
  int passed = 0;
  constexpr int kRays = 40000;
  for (int i = 0; i < kRays; ++i) {
    const Ray up{glm::vec3(-0.9f + 1.8f * rng.uniform(), 1e-3f, -0.9f + 1.8f * rng.uniform()), 0.0f,
                 glm::vec3(0, 1, 0), 10.0f};
    passed += g.engine.occluded(up) ? 0 : 1;
  }
  // Binomial: sigma = sqrt(0.75 * 0.25 / 40000) = 0.0022.
  EXPECT_NEAR(double(passed) / kRays, 0.75, 0.01);
}

TEST(TextureTransport, EmissiveTextureFluxIsItsMeanTimesTheArea) {
  // A chequer of red and green, emission factor 3 (KHR_materials_emissive_strength-like).
  const Material screen = test::chequeredScreen();
  const float height = 10.0f;
  const Scene s = test::emitterOverFloor(screen, height);
  // Radiance 3 x (1/2, 1/2, 0) on average over 1 m^2.
  const SceneGeometry g = SceneGeometry::build(s);
  const double power = std::numbers::pi * 3.0 * 0.5 * (0.2126 + 0.7152);
  EXPECT_NEAR(g.total_emitted_power, power, 0.02 * power);
  // The floor under it: L = rho E / pi, E = pi L_mean F (point-to-polygon form factor).
  const glm::dvec3 corners[4] = {
      {-0.5, height, -0.5}, {0.5, height, -0.5}, {0.5, height, 0.5}, {-0.5, height, 0.5}};
  const double f = pointToPolygonFormFactor(glm::dvec3(0.0), glm::dvec3(0, 1, 0), corners, 4);
  const PathTracer pt(s);
  Rng rng(7, 8);
  PathTracerSettings settings;
  uint64_t rays = 0;
  glm::dvec3 sum(0.0);
  constexpr int kSamples = 20000;
  const glm::vec3 eye(0.3f, 1.0f, 0.0f);
  for (int i = 0; i < kSamples; ++i) {
    sum +=
        glm::dvec3(pt.radiance(Ray{eye, 0.0f, glm::normalize(-eye), 1e30f}, rng, settings, rays));
  }
  const glm::dvec3 got = sum / double(kSamples);
  const double expected = 0.5 * 3.0 * 0.5 * f;  // rho * L_mean * F per channel
  EXPECT_NEAR(got.x, expected, 0.02 * expected);
  EXPECT_NEAR(got.y, expected, 0.02 * expected);
  EXPECT_NEAR(got.z, 0.0, 1e-9);
}

TEST(TextureTransport, OpaqueScenesKeepTheUnfilteredEngine) {
  Scene s = test::floorUnderOccluder(test::maskedLattice(AlphaMode::kOpaque), 1.0f);
  EXPECT_EQ(SceneGeometry::build(s).engine.hitFilter(), nullptr);
  EXPECT_EQ(sceneCutouts(s), nullptr);
}

}  // namespace
}  // namespace penumbra
