// Mirrors and glass (raytrace/specular.h) in the three methods that follow them: the path tracer
// (the reference), Whitted ray tracing and photon mapping. Closed forms (Fresnel, a mirror's
// image of an emitter, a glass sphere in a furnace) and agreement with the path tracer (a mirror
// box, a glass sphere's caustic).
#include "penumbra/raytrace/specular.h"
#include "penumbra/geometry/icosphere.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/raytrace/camera_rays.h"
#include "penumbra/raytrace/path_tracer.h"
#include "penumbra/raytrace/photon_map.h"
#include "penumbra/raytrace/ray_queries.h"
#include "penumbra/raytrace/whitted.h"
#include "penumbra/scene/builtin.h"
#include "support/image_compare.h"
#include "support/test_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <glm/geometric.hpp>
#include <span>

#include <cmath>

namespace penumbra {
namespace {

using test::addQuad;

// Appends a sphere of `radius` at `centre` (icosphere of `level`) of `material` to the scene.
void addSphere(Scene& s, glm::vec3 centre, float radius, int level, uint32_t material) {
  Mesh m = icosphere(level);
  for (glm::vec3& p : m.positions) p = centre + radius * p;
  m.material_ids.assign(m.triangles.size(), material);
  s.meshes.push_back(std::move(m));
}

Material glass(float ior = 1.5f) {
  Material m;
  m.name = "glass";
  m.scattering = Scattering::kDielectric;
  m.ior = ior;
  m.reflectance = diffuseStandIn(m);
  return m;
}

Material mirror(glm::vec3 specular) {
  Material m;
  m.name = "mirror";
  m.scattering = Scattering::kMirror;
  m.specular = specular;
  m.reflectance = diffuseStandIn(m);
  return m;
}

double meanLuminance(const Image& image, const std::vector<uint8_t>* mask = nullptr) {
  double sum = 0.0;
  size_t n = 0;
  for (size_t i = 0; i < image.pixels.size(); ++i) {
    if (mask && !(*mask)[i]) continue;
    const glm::vec3 c = image.pixels[i];
    sum += (double(c.x) + double(c.y) + double(c.z)) / 3.0;
    ++n;
  }
  return n ? sum / double(n) : 0.0;
}

// Fresnel's reflectance at normal incidence ((n - 1) / (n + 1))^2 and at grazing incidence 1;
// the two lobes of clear glass carry all the light; Snell's law holds; beyond the critical angle
// from inside, everything reflects.
TEST(Specular, GlassLobesFollowFresnelAndSnell) {
  const Material g = glass(1.5f);
  const glm::vec3 ng(0.0f, 0.0f, 1.0f);
  SpecularLobes at_normal = specularLobes(g, ng, glm::vec3(0.0f, 0.0f, -1.0f));
  ASSERT_EQ(at_normal.count, 2);
  EXPECT_NEAR(at_normal.fresnel, 0.04, 1e-6);
  Rng rng(3, 4);
  for (int i = 0; i < 1000; ++i) {
    const glm::vec3 d = test::randomDirection(rng);
    const SpecularLobes l = specularLobes(g, ng, d);
    const bool from_front = d.z < 0.0f;
    const double cos_i = std::fabs(double(d.z));
    if (l.count == 1) {
      // Total internal reflection: from inside beyond the critical angle.
      EXPECT_FALSE(from_front);
      EXPECT_GT(std::sqrt(1.0 - cos_i * cos_i) * 1.5, 1.0 - 1e-5);
      EXPECT_EQ(l.lobe[0].weight, glm::vec3(1.0f));
      continue;
    }
    ASSERT_EQ(l.count, 2);
    EXPECT_NEAR(l.lobe[0].weight.x + l.lobe[1].weight.x, 1.0f, 1e-6f);  // clear glass
    // The reflection mirrors d; the refraction obeys n_i sin_i = n_t sin_t on the other side.
    EXPECT_NEAR(l.lobe[0].dir.z, -d.z, 1e-5f);
    const double sin_i = std::sqrt(std::max(0.0, 1.0 - cos_i * cos_i));
    const double cos_t = std::fabs(double(l.lobe[1].dir.z));
    const double sin_t = std::sqrt(std::max(0.0, 1.0 - cos_t * cos_t));
    const double n_i = from_front ? 1.0 : 1.5, n_t = from_front ? 1.5 : 1.0;
    EXPECT_NEAR(n_i * sin_i, n_t * sin_t, 2e-5);
    EXPECT_GT(double(l.lobe[1].dir.z) * double(d.z), 0.0);  // it goes on through the surface
  }
  // A one-sided mirror is black from behind; a two-sided one reflects both ways.
  Material m = mirror(glm::vec3(0.9f, 0.8f, 0.7f));
  EXPECT_EQ(specularLobes(m, ng, glm::vec3(0.0f, 0.6f, 0.8f)).count, 1);
  m.two_sided = false;
  EXPECT_EQ(specularLobes(m, ng, glm::vec3(0.0f, 0.6f, 0.8f)).count, 0);
  const SpecularLobes front = specularLobes(m, ng, glm::vec3(0.0f, 0.6f, -0.8f));
  ASSERT_EQ(front.count, 1);
  EXPECT_EQ(front.lobe[0].weight, glm::vec3(0.9f, 0.8f, 0.7f));
  EXPECT_NEAR(glm::length(front.lobe[0].dir - glm::vec3(0.0f, 0.6f, 0.8f)), 0.0f, 1e-6f);
}

// A camera looking straight at a tinted mirror that reflects an emitter sees specular x Le, the
// same in every method.
TEST(Specular, MirrorShowsTheEmitterTimesItsReflectance) {
  Scene s;
  s.source = "mirror and emitter";
  s.materials.push_back(mirror(glm::vec3(0.9f, 0.6f, 0.3f)));
  Material light;
  light.name = "light";
  light.reflectance = glm::vec3(0.0f);
  light.emission = glm::vec3(2.0f, 3.0f, 4.0f);
  s.materials.push_back(light);
  Mesh m;
  // The mirror at z = 0 facing +z; the emitter, large, at z = 2 facing -z (behind the camera).
  addQuad(m, {-1, -1, 0}, {2, 0, 0}, {0, 2, 0}, 0);
  addQuad(m, {-5, -5, 2}, {0, 10, 0}, {10, 0, 0}, 1);
  s.meshes.push_back(m);
  ASSERT_TRUE(validateScene(s).ok());
  Camera cam;
  cam.position = {0.0f, 0.0f, 1.0f};
  cam.look_at = {0.0f, 0.0f, 0.0f};
  cam.vertical_fov = 0.3f;
  const glm::vec3 expected = glm::vec3(0.9f, 0.6f, 0.3f) * light.emission;

  WhittedTracer whitted(s);
  CpuRayQueries cpu(whitted.geometry().engine);
  WhittedSettings ws;
  ws.width = ws.height = 8;
  ws.spp = 2;
  Expected<Image> w = whitted.render(cam, ws, cpu);
  ASSERT_TRUE(w.ok());
  PathTracer pt(s);
  PathTracerSettings ps;
  ps.width = ps.height = 8;
  ps.spp = 4;
  const Image p = pt.render(cam, ps);
  for (size_t i = 0; i < w->pixels.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(w->pixels[i][c], expected[c], 1e-4f * expected[c]) << i;
      EXPECT_NEAR(p.pixels[i][c], expected[c], 1e-4f * expected[c]) << i;
    }
  }
}

// Energy conservation of the dielectric: a clear glass sphere alone in a uniform environment
// (the furnace) looks exactly like the environment. The path tracer's paths keep weight 1 through
// every Fresnel choice (only Russian roulette adds noise); Whitted's branches split the weight
// into F and 1 - F, so its pixels equal the furnace's value up to the weight left in branches cut
// at the depth limit; photon mapping, with no diffuse surface, is Whitted's image.
//
// Measured (this test's printout): Whitted's mean and exact pixels, the path tracer's mean.
TEST(Specular, GlassSphereInFurnaceKeepsTheFurnaceValue) {
  Scene s;
  s.source = "glass furnace";
  s.materials.push_back(glass(1.5f));
  addSphere(s, glm::vec3(0.0f), 0.5f, 4, 0);
  s.environment = glm::vec3(0.7f);
  ASSERT_TRUE(validateScene(s).ok());
  Camera cam;
  cam.position = {0.0f, 0.3f, 2.0f};
  cam.look_at = {0.0f, 0.0f, 0.0f};
  cam.vertical_fov = 0.55f;  // the sphere fills most of the view

  WhittedTracer whitted(s);
  CpuRayQueries cpu(whitted.geometry().engine);
  WhittedSettings ws;
  ws.width = ws.height = 24;
  ws.spp = 2;
  ws.max_depth = 24;
  Expected<Image> w = whitted.render(cam, ws, cpu);
  ASSERT_TRUE(w.ok());
  // Light caught by total internal reflection between the facets loses what its branch carries
  // when the depth limit cuts it: a few pixels are darker; every other one is exact, up to the
  // branches fainter than 1e-4, which go on by Russian roulette (whitted.cpp) and move a pixel by
  // a few 1e-4 at most. Which pixels have a sample on such a path depends on where the samples
  // fall: 94-95% of them are exact with stratified or independent jitter.
  size_t exact = 0;
  for (const glm::vec3& c : w->pixels) {
    EXPECT_LE(c.x, 0.7f + 5e-4f);
    exact += std::fabs(c.x - 0.7f) < 2e-4f;
  }
  EXPECT_GT(exact, w->pixels.size() * 93 / 100);
  EXPECT_NEAR(meanLuminance(*w), 0.7, 0.7 * 0.01);
  PhotonSettings photon_settings;
  photon_settings.photons = 20000;
  photon_settings.caustic_photons = 20000;
  Expected<PhotonMaps> maps = shootPhotons(s, whitted.geometry(), photon_settings, cpu);
  ASSERT_TRUE(maps.ok());
  Expected<Image> ph = whitted.render(cam, ws, cpu, nullptr, {},
                                      photonShading(whitted.geometry(), *maps, photon_settings));
  ASSERT_TRUE(ph.ok());
  for (size_t i = 0; i < ph->pixels.size(); ++i) EXPECT_EQ(ph->pixels[i], w->pixels[i]);

  PathTracer pt(s);
  PathTracerSettings ps;
  ps.width = ps.height = 24;
  ps.spp = 64;
  const Image p = pt.render(cam, ps);
  // Russian roulette (survival 0.99 per vertex after the third) is the only noise: a path is
  // worth 0.7 / 0.99^k or 0, heavy-tailed where the facets trap light by total internal
  // reflection for hundreds of bounces. The mean is the furnace's value within half a percent,
  // and nine pixels in ten within 5%.
  EXPECT_NEAR(meanLuminance(p), 0.7, 0.7 * 0.005);
  size_t near = 0;
  for (const glm::vec3& c : p.pixels) near += std::fabs(c.x - 0.7f) < 0.035f;
  EXPECT_GT(near, p.pixels.size() * 9 / 10);
  std::printf(
      "glass furnace 0.7: whitted mean %.5f (%zu of %zu pixels exact), path tracer mean "
      "%.5f\n",
      meanLuminance(*w), exact, w->pixels.size(), meanLuminance(p));
}

// Glass in glass in glass, 40 generations deep: every split doubles the rays, so the tree would
// hold 2^40 branches; faint branches going on by Russian roulette and generations traced in chunks
// keep it bounded, and it stays energy-conserving in the furnace (unbiased, so the mean is the
// furnace's value up to noise).
TEST(Whitted, GlassInGlassStaysBoundedAndConservesEnergy) {
  Scene s;
  s.source = "nested glass";
  s.materials.push_back(glass(1.5f));
  s.materials.push_back(glass(1.33f));
  for (int i = 0; i < 3; ++i)
    addSphere(s, glm::vec3(0.0f), 0.5f - 0.12f * float(i), 3, uint32_t(i % 2));
  s.environment = glm::vec3(0.7f);
  ASSERT_TRUE(validateScene(s).ok());
  Camera cam;
  cam.position = {0.0f, 0.2f, 2.0f};
  cam.look_at = {0.0f, 0.0f, 0.0f};
  cam.vertical_fov = 0.55f;
  WhittedTracer whitted(s);
  CpuRayQueries cpu(whitted.geometry().engine);
  WhittedSettings ws;
  ws.width = ws.height = 16;
  ws.spp = 2;
  ws.max_depth = 40;
  WhittedStats stats;
  Expected<Image> w = whitted.render(cam, ws, cpu, &stats);
  ASSERT_TRUE(w.ok());
  std::printf("nested glass, depth 40: mean %.5f, %llu rays for %d camera rays\n",
              meanLuminance(*w), static_cast<unsigned long long>(stats.rays),
              ws.width * ws.height * ws.spp);
  EXPECT_NEAR(meanLuminance(*w), 0.7, 0.7 * 0.03);
  EXPECT_LT(stats.rays, uint64_t(ws.width * ws.height * ws.spp) * 20000);
}

// The Cornell box with a mirror ball and a glass ball: Whitted's image is the path tracer's
// light of the paths camera (mirror | glass)* diffuse light (PathTracerSettings::direct_only).
// Both are unbiased estimates of that light; the image means and 4x4 blocks agree within their
// noise.
Scene mirrorBox(int sphere_level) {
  Expected<Scene> base = builtinScene("cornell");
  EXPECT_TRUE(base.ok());
  Scene s = *base;
  s.source = "mirror box";
  // The boxes make way for two balls, a mirror and a glass one, and the red wall becomes a mirror.
  std::erase_if(s.meshes,
                [](const Mesh& m) { return m.name == "smallbox" || m.name == "largebox"; });
  s.materials.push_back(mirror(glm::vec3(0.9f)));
  const uint32_t mirror_id = uint32_t(s.materials.size() - 1);
  s.materials.push_back(glass(1.5f));
  const uint32_t glass_id = uint32_t(s.materials.size() - 1);
  for (Mesh& m : s.meshes) {
    if (m.name == "redwall") {
      m.material_ids.assign(m.triangles.size(), mirror_id);
    }
  }
  addSphere(s, {0.17f, 0.09f, 0.36f}, 0.09f, sphere_level, mirror_id);
  addSphere(s, {0.39f, 0.09f, 0.17f}, 0.09f, sphere_level, glass_id);
  EXPECT_TRUE(validateScene(s).ok());
  return s;
}

TEST(Whitted, MirrorBoxAgreesWithPathTracerOnDirectAndSpecularPaths) {
  const Scene s = mirrorBox(3);
  bool has_mirror_wall = false;
  for (const Mesh& m : s.meshes) {
    has_mirror_wall |= m.material_ids[0] == s.materials.size() - 2 && m.name != "sphere";
  }
  ASSERT_TRUE(has_mirror_wall) << "the box's red wall was not found to make it a mirror";
  const Camera cam = *s.camera;
  WhittedTracer whitted(s);
  CpuRayQueries cpu(whitted.geometry().engine);
  WhittedSettings ws;
  ws.width = ws.height = 32;
  ws.spp = 128;
  ws.light_samples = 8;
  ws.max_depth = 12;
  Expected<Image> w = whitted.render(cam, ws, cpu);
  ASSERT_TRUE(w.ok());
  PathTracer pt(s);
  PathTracerSettings ps;
  ps.width = ps.height = 32;
  ps.spp = 4096;
  ps.direct_only = true;
  ps.max_depth = 13;  // the camera vertex and Whitted's 12 generations
  const Image p = pt.render(cam, ps);
  const double mw = meanLuminance(*w), mp = meanLuminance(p);
  EXPECT_NEAR(mw / mp, 1.0, 0.01) << "whitted " << mw << ", path tracer " << mp;
  // 8x8-pixel blocks: each within 5%, the noise of both images where the light is seen through
  // glass and in mirrors (measured: 3.1% at worst).
  double worst = 0.0;
  for (int by = 0; by < 4; ++by) {
    for (int bx = 0; bx < 4; ++bx) {
      double a = 0.0, b = 0.0;
      for (int y = by * 8; y < by * 8 + 8; ++y) {
        for (int x = bx * 8; x < bx * 8 + 8; ++x) {
          const size_t i = size_t(y) * 32 + size_t(x);
          a += double(glm::dot(w->pixels[i], glm::vec3(1.0f)));
          b += double(glm::dot(p.pixels[i], glm::vec3(1.0f)));
        }
      }
      worst = std::max(worst, std::fabs(a / b - 1.0));
    }
  }
  EXPECT_LT(worst, 0.05);
  std::printf("mirror box: whitted %.5f, path tracer (direct only) %.5f; worst 8x8 block %.2f%%\n",
              mw, mp, 100.0 * worst);
}

// Relative RMS difference of two images over every pixel.
double relativeRms(const Image& a, const Image& b) {
  return test::relativeRms(a, b, std::vector<uint8_t>(a.pixels.size(), 1));
}

// Whitted and photon mapping trace every batch through whichever back end they are given: the
// CPU engine, the GPU kernel and the CPU/GPU split give the same image, up to the split's
// last-bit differences in t (which move a few refracted rays across a facet edge).
TEST(Whitted, SameImageOnEveryBackEnd) {
  const Scene s = mirrorBox(2);
  WhittedTracer whitted(s);
  WhittedSettings ws;
  ws.width = 24;
  ws.height = 20;
  ws.spp = 2;
  ws.light_samples = 2;
  PhotonSettings photon_settings;
  photon_settings.photons = 20000;
  photon_settings.caustic_photons = 20000;
  photon_settings.final_gather = 4;
  CpuRayQueries cpu(whitted.geometry().engine);
  Expected<Image> reference = whitted.render(*s.camera, ws, cpu);
  ASSERT_TRUE(reference.ok());
  Expected<PhotonMaps> cpu_maps = shootPhotons(s, whitted.geometry(), photon_settings, cpu);
  ASSERT_TRUE(cpu_maps.ok());
  Expected<Image> photon_reference =
      whitted.render(*s.camera, ws, cpu, nullptr, {},
                     photonShading(whitted.geometry(), *cpu_maps, photon_settings));
  ASSERT_TRUE(photon_reference.ok());

  PENUMBRA_GL_OR_SKIP();
  const SceneGeometry& g = whitted.geometry();
  Expected<std::unique_ptr<OwnedRayQueries>> gpu = OwnedRayQueries::make("gpu", g);
  ASSERT_TRUE(gpu.ok()) << gpu.error().describe();
  HybridOptions split;
  split.t_min = 2;  // a small scene: cells of a few triangles, so the GPU takes some rays
  split.t_max = 64;
  split.r_min = 16;
  Expected<HybridRayEngine> hy = HybridRayEngine::build(g.positions, g.triangles, split);
  ASSERT_TRUE(hy.ok()) << hy.error().describe();
  HybridRayQueries hybrid(*hy);
  for (RayQueries* q : std::initializer_list<RayQueries*>{gpu->get(), &hybrid}) {
    Expected<Image> img = whitted.render(*s.camera, ws, *q);
    ASSERT_TRUE(img.ok()) << img.error().describe();
    EXPECT_LT(relativeRms(*img, *reference), 1e-4);
    Expected<PhotonMaps> maps = shootPhotons(s, g, photon_settings, *q);
    ASSERT_TRUE(maps.ok());
    EXPECT_NEAR(double(maps->global.photons().size()), double(cpu_maps->global.photons().size()),
                0.01 * double(cpu_maps->global.photons().size()));
    Expected<Image> ph =
        whitted.render(*s.camera, ws, *q, nullptr, {}, photonShading(g, *maps, photon_settings));
    ASSERT_TRUE(ph.ok());
    EXPECT_LT(relativeRms(*ph, *photon_reference), 1e-3);
    std::printf("whitted %.2g, photons %.2g relative RMS from the CPU's\n",
                relativeRms(*img, *reference), relativeRms(*ph, *photon_reference));
  }
  EXPECT_GT(hybrid.stats().gpu_batches, 0u);
}

// A glass ball's caustic on a floor, lit by a small area light off to the side: photon mapping's
// mean radiance over the caustic (the ball's shadow, where almost all light comes through the
// glass) agrees with the path tracer's within 3%. Measured: -0.7% to +1.5% over three seeds of
// both; the path tracer's own noise here is about 1%, and the photons' density estimates blur
// the caustic's bright focus (which is why the region spans 700 pixels, not a few).
TEST(Photons, GlassSphereCausticMatchesPathTracer) {
  Scene s;
  s.source = "caustic";
  Material floor;
  floor.name = "floor";
  floor.reflectance = glm::vec3(0.8f);
  s.materials.push_back(floor);
  s.materials.push_back(glass(1.5f));
  Material light;
  light.name = "light";
  light.reflectance = glm::vec3(0.0f);
  light.emission = glm::vec3(100.0f);
  s.materials.push_back(light);
  Mesh ground;
  addQuad(ground, {-1, 0, 1}, {2, 0, 0}, {0, 0, -2}, 0);
  s.meshes.push_back(ground);
  const glm::vec3 centre(0.0f, 0.12f, 0.0f);
  addSphere(s, centre, 0.1f, 5, 1);
  // The light: 0.1 m square at (0.5, 1, 0), facing the ball.
  const glm::vec3 at(0.5f, 1.0f, 0.0f);
  const glm::vec3 n = glm::normalize(centre - at);
  const glm::vec3 u = glm::normalize(glm::cross(n, glm::vec3(0, 0, 1))) * 0.05f;
  const glm::vec3 v = glm::cross(n, u);
  Mesh lamp;
  lamp.positions = {at - u - v, at - u + v, at + u + v, at + u - v};
  const bool ccw = glm::dot(glm::cross(lamp.positions[1] - lamp.positions[0],
                                       lamp.positions[2] - lamp.positions[0]),
                            n) > 0.0f;
  lamp.triangles = ccw ? std::vector<glm::uvec3>{{0, 1, 2}, {0, 2, 3}}
                       : std::vector<glm::uvec3>{{0, 2, 1}, {0, 3, 2}};
  lamp.material_ids = {2, 2};
  s.meshes.push_back(lamp);
  ASSERT_TRUE(validateScene(s).ok());
  // The caustic's centre: where the line from the light through the ball meets the floor.
  const glm::vec3 d = glm::normalize(centre - at);
  const glm::vec3 focus = centre + d * (centre.y / -d.y);
  Camera cam;
  cam.position = focus + glm::vec3(-0.25f, 0.6f, 0.0f);
  cam.look_at = focus;
  cam.vertical_fov = 0.45f;

  // The region: pixels whose camera ray meets the floor within 6 cm of the caustic's centre.
  const int size = 96;
  WhittedTracer whitted(s);
  const CameraRays rays(cam, size, size);
  std::vector<uint8_t> region(size_t(size) * size, 0);
  size_t in_region = 0;
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const Ray r = rays.ray(float(x) + 0.5f, float(y) + 0.5f);
      const Hit h = whitted.geometry().engine.intersect(r);
      if (!h.hit() || whitted.geometry().material_ids[size_t(h.triangle)] != 0) continue;
      const glm::vec3 p = r.origin + h.t * r.dir;
      if (glm::length(p - focus) < 0.06f) {
        region[size_t(y) * size + size_t(x)] = 1;
        ++in_region;
      }
    }
  }
  ASSERT_GT(in_region, 600u);

  CpuRayQueries cpu(whitted.geometry().engine);
  PhotonSettings photon_settings;
  photon_settings.photons = 100000;
  photon_settings.caustic_photons = 1000000;
  photon_settings.final_gather = 16;
  photon_settings.gather_radius = 0.005f;
  PhotonStats stats;
  Expected<PhotonMaps> maps = shootPhotons(s, whitted.geometry(), photon_settings, cpu, &stats);
  ASSERT_TRUE(maps.ok());
  EXPECT_GT(stats.caustic_stored, 100000u);
  // Both estimates converged enough that their noise stays well inside the 3% compared: the
  // region's mean moves by up to 2.5% between sample patterns at 4 to 16 view rays per pixel (the
  // final gather's noise), and the path tracer's caustic (found only by paths that reach the lamp
  // through the glass) by about 2% at 1,024 spp; at 64 and 4,096 both are within 0.6% of their
  // values at 8,192 spp.
  WhittedSettings ws;
  ws.width = ws.height = size;
  ws.spp = 64;
  ws.light_samples = 4;
  Expected<Image> ph = whitted.render(cam, ws, cpu, nullptr, {},
                                      photonShading(whitted.geometry(), *maps, photon_settings));
  ASSERT_TRUE(ph.ok());

  // The path tracer on the region's rows only.
  int y_first = size, y_last = -1;
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      if (!region[size_t(y) * size + size_t(x)]) continue;
      y_first = std::min(y_first, y);
      y_last = std::max(y_last, y);
    }
  }
  PathTracer pt(s);
  PathTracerSettings ps;
  ps.width = ps.height = size;
  ps.spp = 4096;
  Image p(size, size);
  (void)pt.renderRows(
      cam, ps, y_first, y_last + 1,
      std::span<glm::vec3>(p.pixels).subspan(size_t(y_first) * size_t(size),
                                             size_t(y_last + 1 - y_first) * size_t(size)));
  const double m_ph = meanLuminance(*ph, &region), m_pt = meanLuminance(p, &region);
  // The direct light alone (Whitted), to show the caustic is most of what the region receives.
  WhittedSettings direct_settings = ws;
  direct_settings.spp = 4;
  Expected<Image> direct = whitted.render(cam, direct_settings, cpu);
  ASSERT_TRUE(direct.ok());
  const double m_direct = meanLuminance(*direct, &region);
  std::printf(
      "caustic region (%zu pixels): photons %.4f, path tracer %.4f (%.2f%%); direct light "
      "alone %.4f\n",
      in_region, m_ph, m_pt, 100.0 * (m_ph / m_pt - 1.0), m_direct);
  EXPECT_LT(m_direct, 0.7 * m_pt) << "the region should be lit mostly through the glass";
  EXPECT_NEAR(m_ph / m_pt, 1.0, 0.03);
}

// Real scenes, every kind of light: the room (the 69k-triangle scan, single-quad walls, one wound
// outwards, a point light and an emissive panel), the studio (glTF: a spot light, an emissive
// panel, its camera) and the office (six EULUMDAT luminaires). Photon mapping's image against the
// path tracer's: the mean within 2.5%, 8x8-pixel blocks within 4% RMS (measured on the final code:
// see the printout). Whitted's against the path tracer's direct light (direct_only): within 1.5%.
TEST(Photons, RealScenesAgreeWithThePathTracer) {
  const std::string scenes = std::string(PENUMBRA_TEST_DATA) + "/../../scenes/";
  for (const char* name : {"room.json", "studio.gltf", "office.json"}) {
    Expected<Scene> s = loadScene(scenes + name);
    ASSERT_TRUE(s.ok()) << s.error().describe();
    const Camera cam = s->camera ? *s->camera : defaultCamera(*s);
    WhittedTracer whitted(*s);
    CpuRayQueries cpu(whitted.geometry().engine);
    WhittedSettings ws;
    ws.width = 64;
    ws.height = 48;
    ws.spp = 4;
    PhotonSettings photon_settings;
    photon_settings.photons = 200000;
    Expected<PhotonMaps> maps = shootPhotons(*s, whitted.geometry(), photon_settings, cpu);
    ASSERT_TRUE(maps.ok());
    Expected<Image> ph = whitted.render(cam, ws, cpu, nullptr, {},
                                        photonShading(whitted.geometry(), *maps, photon_settings));
    ASSERT_TRUE(ph.ok());
    WhittedSettings direct_settings = ws;
    direct_settings.spp = 4;
    Expected<Image> direct = whitted.render(cam, direct_settings, cpu);
    ASSERT_TRUE(direct.ok());
    PathTracer pt(*s);
    PathTracerSettings ps;
    ps.width = 64;
    ps.height = 48;
    ps.spp = 256;
    const Image p = pt.render(cam, ps);
    ps.direct_only = true;
    ps.spp = 64;
    const Image pd = pt.render(cam, ps);
    const test::BlockComparison blocks = test::compareBlocks(*ph, p, 8, 1e30);
    const double m_ph = meanLuminance(*ph), m_pt = meanLuminance(p);
    const double m_w = meanLuminance(*direct), m_pd = meanLuminance(pd);
    std::printf(
        "%s: photons %.5f, path tracer %.5f (%+.2f%%), 8x8 blocks %.2f%% RMS; whitted "
        "%.5f, direct light %.5f (%+.2f%%)\n",
        name, m_ph, m_pt, 100.0 * (m_ph / m_pt - 1.0), 100.0 * blocks.block_rms, m_w, m_pd,
        100.0 * (m_w / m_pd - 1.0));
    EXPECT_NEAR(m_ph / m_pt, 1.0, 0.025) << name;
    EXPECT_LT(blocks.block_rms, 0.04) << name;
    EXPECT_NEAR(m_w / m_pd, 1.0, 0.015) << name;
  }
}

}  // namespace
}  // namespace penumbra
