// The reference path tracer against closed forms: delta and area lights, the furnace, and
// translucent media (the random walk) against the white furnace with a medium and the albedo of a
// semi-infinite medium from Chandrasekhar's H-function.
#include "penumbra/raytrace/path_tracer.h"

#include "penumbra/core/parallel.h"
#include "penumbra/kernels/dipole.h"
#include "penumbra/kernels/sampling.h"
#include "penumbra/raytrace/ray_queries.h"
#include "penumbra/scene/builtin.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>

#include <array>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

namespace penumbra {
namespace {

// A scene with a large horizontal floor (y = 0) of reflectance rho.
Scene floorScene(float rho, float half_size = 1000.0f) {
  Scene s;
  s.source = "test:floor";
  s.materials.push_back({"floor", glm::vec3(rho), glm::vec3(0.0f)});
  Mesh m;
  m.name = "floor";
  const float h = half_size;
  m.positions = {{-h, 0, -h}, {-h, 0, h}, {h, 0, h}, {h, 0, -h}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  m.material_ids = {0, 0};
  s.meshes.push_back(m);
  return s;
}

// Mean radiance of `n` samples along the ray from `eye` to `target`.
glm::vec3 meanRadiance(const PathTracer& pt, glm::vec3 eye, glm::vec3 target, int n) {
  Rng rng(1, 2);
  PathTracerSettings settings;
  uint64_t rays = 0;
  glm::dvec3 sum(0.0);
  Ray ray;
  ray.origin = eye;
  ray.dir = glm::normalize(target - eye);
  for (int i = 0; i < n; ++i) sum += glm::dvec3(pt.radiance(ray, rng, settings, rays));
  return glm::vec3(sum / double(n));
}

TEST(PathTracer, PointLightFollowsTheInverseSquareCosineLaw) {
  Scene s = floorScene(0.5f);
  const glm::vec3 light_pos(0.0f, 2.0f, 0.0f);
  s.lights.push_back(PointLight{light_pos, glm::vec3(10.0f, 5.0f, 1.0f)});
  ASSERT_TRUE(validateScene(s).ok());
  const PathTracer pt(s);
  for (const glm::vec3 x :
       {glm::vec3(0, 0, 0), glm::vec3(1, 0, 0.5f), glm::vec3(3, 0, 0), glm::vec3(-6, 0, 2)}) {
    const glm::vec3 d = light_pos - x;
    const float r2 = glm::dot(d, d);
    const float cos_theta = d.y / std::sqrt(r2);
    const glm::vec3 expected = 0.5f * kInvPi * glm::vec3(10.0f, 5.0f, 1.0f) * cos_theta / r2;
    const glm::vec3 got = meanRadiance(pt, x + glm::vec3(0.3f, 1.0f, -0.2f), x, 16);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], expected[c], 1e-4f * expected[c]) << x.x;
  }
}

TEST(PathTracer, SpotLightFallsOffBetweenItsCones) {
  Scene s = floorScene(0.8f, 10.0f);  // small, so hit points carry little rounding error
  SpotLight spot;
  spot.position = glm::vec3(0.0f, 1.0f, 0.0f);
  spot.direction = glm::vec3(0.0f, -1.0f, 0.0f);
  spot.intensity = glm::vec3(4.0f);
  spot.inner_angle = glm::radians(20.0f);
  spot.outer_angle = glm::radians(40.0f);
  s.lights.push_back(spot);
  ASSERT_TRUE(validateScene(s).ok());
  const PathTracer pt(s);
  for (const float angle_deg : {0.0f, 10.0f, 30.0f, 35.0f, 45.0f}) {
    const float a = glm::radians(angle_deg);
    const glm::vec3 x(std::tan(a), 0.0f, 0.0f);
    float falloff = 1.0f;
    if (angle_deg > 20.0f) {
      const float f =
          std::clamp((std::cos(a) - std::cos(glm::radians(40.0f))) /
                         (std::cos(glm::radians(20.0f)) - std::cos(glm::radians(40.0f))),
                     0.0f, 1.0f);
      falloff = f * f;
    }
    const float r2 = 1.0f + x.x * x.x;
    const float expected = 0.8f * kInvPi * 4.0f * falloff * std::cos(a) / r2;
    const glm::vec3 got = meanRadiance(pt, x + glm::vec3(0.0f, 0.5f, 0.5f), x, 4);
    EXPECT_NEAR(got.x, expected, 1e-4f * std::max(expected, 1e-3f)) << angle_deg;
  }
}

TEST(PathTracer, DirectionalLightGivesRhoOverPiTimesIrradianceCosine) {
  Scene s = floorScene(0.6f);
  s.lights.push_back(
      DirectionalLight{glm::normalize(glm::vec3(1.0f, -1.0f, 0.0f)), glm::vec3(3.0f)});
  ASSERT_TRUE(validateScene(s).ok());
  const PathTracer pt(s);
  const glm::vec3 got = meanRadiance(pt, glm::vec3(0.0f, 1.0f, 1.0f), glm::vec3(0.0f), 4);
  EXPECT_NEAR(got.x, 0.6f * kInvPi * 3.0f * std::sqrt(0.5f), 1e-5f);
}

// Lambert's formula for the form factor from a differential area at x (normal n) to a polygon.
double pointToPolygonFormFactor(glm::dvec3 x, glm::dvec3 n, const std::vector<glm::dvec3>& poly) {
  double sum = 0.0;
  for (size_t i = 0; i < poly.size(); ++i) {
    const glm::dvec3 a = glm::normalize(poly[i] - x);
    const glm::dvec3 b = glm::normalize(poly[(i + 1) % poly.size()] - x);
    const double gamma = std::acos(std::clamp(glm::dot(a, b), -1.0, 1.0));
    sum += gamma * glm::dot(n, glm::normalize(glm::cross(a, b)));
  }
  return std::fabs(sum) / (2.0 * 3.14159265358979323846);
}

// An emissive square above the floor: radiance leaving the floor is rho * Le * F(x -> square),
// which exercises emitter sampling, BSDF sampling and their MIS weights together.
TEST(PathTracer, AreaLightMatchesThePointToPolygonFormFactor) {
  Scene s = floorScene(0.5f);
  s.materials.push_back({"emitter", glm::vec3(0.0f), glm::vec3(2.0f)});
  Mesh e;
  e.name = "emitter";
  const std::vector<glm::dvec3> quad = {
      {-0.5, 1, -0.5}, {0.5, 1, -0.5}, {0.5, 1, 0.5}, {-0.5, 1, 0.5}};
  for (const auto& q : quad) e.positions.emplace_back(q);
  e.triangles = {{0, 1, 2}, {0, 2, 3}};  // counter-clockwise from below: faces down
  e.material_ids = {1, 1};
  s.meshes.push_back(e);
  ASSERT_TRUE(validateScene(s).ok());
  const PathTracer pt(s);
  for (const glm::vec3 x : {glm::vec3(0, 0, 0), glm::vec3(0.8f, 0, 0.3f), glm::vec3(2.0f, 0, 0)}) {
    const double f = pointToPolygonFormFactor(glm::dvec3(x), glm::dvec3(0, 1, 0), quad);
    const double expected = 0.5 * 2.0 * f;
    const glm::vec3 got = meanRadiance(pt, x + glm::vec3(1.5f, 0.4f, 0.0f), x, 40000);
    EXPECT_NEAR(got.x, expected, 0.01 * expected) << "at x = " << x.x << ", F = " << f;
  }
}

TEST(PathTracer, FurnaceGivesRadianceTwo) {
  Expected<Scene> s = builtinScene("furnace");
  ASSERT_TRUE(s.ok());
  const PathTracer pt(*s);
  PathTracerSettings settings;
  settings.width = settings.height = 24;
  settings.spp = 256;
  const Image img = pt.render(*s->camera, settings);
  double sum = 0.0;
  float worst = 0.0f;
  for (const glm::vec3& p : img.pixels) {
    sum += double(p.x + p.y + p.z) / 3.0;
    worst = std::max(worst, std::fabs(p.x - 2.0f));
  }
  const double mean = sum / double(img.pixels.size());
  EXPECT_NEAR(mean, 2.0, 0.02);  // 1% over the image
  EXPECT_LT(worst, 0.2f);        // and no pixel far off
}

// A black room 4 m x 3 m x 4 m with a floor of reflectance 0.5 under a 1 m x 1 m roof opening
// and a uniform sky (CIE type 5): the floor's radiance is rho L F, F the configuration factor
// from the point to the opening in closed form. The sky is sampled through the opening as a
// portal and weighted against the bounce by MIS: 256 paths come within 3% (by bounces alone,
// with the portals switched off, the same points came out 8-18% off).
TEST(PathTracer, SkyThroughAnOpeningIsSampledAsAPortal) {
  Scene s;
  s.source = "test:roof light";
  s.materials = {{"black", glm::vec3(0.0f), glm::vec3(0.0f)},
                 {"floor", glm::vec3(0.5f), glm::vec3(0.0f)}};
  Mesh room;
  test::addQuad(room, {0, 0, 0}, {0, 0, 4}, {4, 0, 0}, 1);   // floor, facing up
  test::addQuad(room, {0, 0, 0}, {4, 0, 0}, {0, 3, 0}, 0);   // z = 0, facing +z
  test::addQuad(room, {4, 0, 4}, {-4, 0, 0}, {0, 3, 0}, 0);  // z = 4, facing -z
  test::addQuad(room, {0, 0, 4}, {0, 0, -4}, {0, 3, 0}, 0);  // x = 0, facing +x
  test::addQuad(room, {4, 0, 0}, {0, 0, 4}, {0, 3, 0}, 0);   // x = 4, facing -x
  // The ceiling (facing down) less the opening (1.5, 2.5) x (1.5, 2.5).
  for (const auto& [x0, x1, z0, z1] :
       {std::array<float, 4>{0, 1.5f, 0, 4}, std::array<float, 4>{2.5f, 4, 0, 4},
        std::array<float, 4>{1.5f, 2.5f, 0, 1.5f}, std::array<float, 4>{1.5f, 2.5f, 2.5f, 4}}) {
    test::addQuad(room, {x0, 3, z0}, {x1 - x0, 0, 0}, {0, 0, z1 - z0}, 0);
  }
  s.meshes.push_back(room);
  Sky sky;
  sky.type = 5;
  sky.zenith_luminance = 1000.0;
  sky.prepare();
  s.sky = sky;
  Opening opening;
  opening.name = "roof light";
  opening.corners = {{1.5, 3, 1.5}, {2.5, 3, 1.5}, {2.5, 3, 2.5}, {1.5, 3, 2.5}};
  s.openings.push_back(opening);
  ASSERT_TRUE(validateScene(s).ok());
  const PathTracer pt(s);
  const glm::vec3 l_sky = s.sky->radiance(glm::dvec3(0.0, 1.0, 0.0));
  const std::vector<glm::dvec3> poly = {{1.5, 3, 1.5}, {2.5, 3, 1.5}, {2.5, 3, 2.5}, {1.5, 3, 2.5}};
  for (const glm::vec3 x : {glm::vec3(2, 0, 2), glm::vec3(0.5f, 0, 1), glm::vec3(3.5f, 0, 3.5f)}) {
    const double f = pointToPolygonFormFactor(glm::dvec3(x), glm::dvec3(0, 1, 0), poly);
    const double expected = 0.5 * double(l_sky.y) * f;
    const glm::vec3 got = meanRadiance(pt, x + glm::vec3(0.3f, 1.0f, -0.2f), x, 256);
    EXPECT_NEAR(got.y, expected, 0.03 * expected) << x.x << " " << x.z << ", F " << f;
  }
}

TEST(PathTracer, ImageDoesNotDependOnTheThreadCount) {
  Expected<Scene> s = builtinScene("cornell");
  ASSERT_TRUE(s.ok());
  const PathTracer pt(*s);
  PathTracerSettings settings;
  settings.width = settings.height = 24;
  settings.spp = 8;
  settings.seed = 42;
  Image one, two;
  {
    auto limit = limitThreads(1);
    one = pt.render(*s->camera, settings);
  }
  {
    auto limit = limitThreads(2);
    two = pt.render(*s->camera, settings);
  }
  for (size_t i = 0; i < one.pixels.size(); ++i) ASSERT_EQ(one.pixels[i], two.pixels[i]) << i;
  settings.seed = 43;
  const Image other = pt.render(*s->camera, settings);
  EXPECT_NE(other.pixels, one.pixels);  // the seed matters
}

// --- Translucent media and the uniform environment --------------------------------------------

// A scene of one closed translucent box of the given size, centred at `centre`, lit only by the
// uniform environment `env`. Its material's reflectance is 0.3: the path tracer must ignore it.
Scene translucentBoxScene(const Subsurface& medium, glm::dvec3 size, glm::vec3 centre, float env) {
  Scene s;
  s.source = "test:translucent-box";
  Material m{"medium", glm::vec3(0.3f), glm::vec3(0.0f)};
  m.subsurface = medium;
  s.materials.push_back(m);
  Mesh box = test::boxMesh(size.x, size.y, size.z);
  for (glm::vec3& p : box.positions) p += centre - 0.5f * glm::vec3(size);
  s.meshes.push_back(box);
  s.environment = glm::vec3(env);
  return s;
}

Subsurface medium(glm::dvec3 sigma_s_prime, glm::dvec3 sigma_a, double eta) {
  Subsurface m;
  m.sigma_s_prime = sigma_s_prime;
  m.sigma_a = sigma_a;
  m.eta = eta;
  return m;
}

// Per-channel mean and standard error of n one-sample estimates; sample i draws its ray and its
// path from its own stream, so the result does not depend on the thread count.
struct Estimate {
  glm::dvec3 mean{0.0};
  glm::dvec3 std_error{0.0};
  bool finite = true;
  std::vector<glm::dvec3> samples;
};

template <typename MakeRay>
Estimate estimate(const PathTracer& pt, const PathTracerSettings& settings, size_t n, uint64_t seed,
                  MakeRay make_ray) {
  Estimate e;
  e.samples.resize(n);
  parallelRange(n, 256, [&](size_t b, size_t end) {
    uint64_t rays = 0;
    for (size_t i = b; i < end; ++i) {
      Rng rng(seed, i);
      const Ray ray = make_ray(rng);
      e.samples[i] = glm::dvec3(pt.radiance(ray, rng, settings, rays));
    }
  });
  glm::dvec3 sum(0.0), sum2(0.0);
  for (const glm::dvec3& v : e.samples) {
    e.finite = e.finite && std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
    sum += v;
    sum2 += v * v;
  }
  e.mean = sum / double(n);
  e.std_error = glm::sqrt(glm::max(sum2 / double(n) - e.mean * e.mean, 0.0) / double(n - 1));
  return e;
}

// Camera rays at the furnace box: from a sphere of radius 1 around it towards a point inside.
Ray rayAtBox(Rng& rng, float half) {
  Ray r;
  r.origin = test::randomDirection(rng);
  const glm::vec3 target = test::randomInBox(rng, -half, half);
  r.dir = glm::normalize(target - r.origin);
  return r;
}

// The white furnace with a medium: inside a uniform environment of radiance 1, a closed body
// that neither absorbs nor emits returns exactly what it receives, so every camera ray sees 1,
// whatever the index of refraction or the (channel-dependent) scattering. A 10 cm box, optical
// size 15 to 30 mean free paths: the walk takes tens to hundreds of events (total internal
// reflection at eta 1.3 adds more). With grey coefficients every weight on the path is 1 and
// every sample must be 1 (up to float rounding over the walk's events). Different sigma_s' per
// channel make the path's spectral MIS weights differ from 1, so the estimate has noise and tests
// their unbiasedness per channel: the mean must be within 4 standard errors (estimated from the
// samples themselves; a 6e-5 chance per channel of failing by noise) of 1. The material's
// reflectance (0.3) must play no part.
TEST(PathTracer, WhiteFurnaceWithAMediumReturnsTheEnvironment) {
  {
    Scene s = translucentBoxScene(medium(glm::dvec3(200.0), glm::dvec3(0.0), 1.3), glm::dvec3(0.1),
                                  glm::vec3(0.0f), 1.0f);
    ASSERT_TRUE(validateScene(s).ok());
    const PathTracer pt(s);
    const Estimate e =
        estimate(pt, PathTracerSettings{}, 4000, 6, [](Rng& rng) { return rayAtBox(rng, 0.04f); });
    for (const glm::dvec3& v : e.samples) {
      ASSERT_NEAR(v.x, 1.0, 1e-4);
      ASSERT_EQ(v.x, v.y);
      ASSERT_EQ(v.x, v.z);
    }
  }
  for (const double eta : {1.3, 1.0}) {
    SCOPED_TRACE(eta);
    Scene s = translucentBoxScene(medium({150.0, 200.0, 300.0}, glm::dvec3(0.0), eta),
                                  glm::dvec3(0.1), glm::vec3(0.0f), 1.0f);
    ASSERT_TRUE(validateScene(s).ok());
    const PathTracer pt(s);
    const Estimate e =
        estimate(pt, PathTracerSettings{}, 40000, 7, [](Rng& rng) { return rayAtBox(rng, 0.04f); });
    EXPECT_TRUE(e.finite);
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(e.mean[c], 1.0, 4.0 * e.std_error[c] + 1e-6) << "channel " << c;
      EXPECT_LT(e.std_error[c], 0.02) << "channel " << c;  // the MIS weights stay tame
    }
    const std::string key = eta == 1.0 ? "eta_1" : "eta_1.3";
    for (int c = 0; c < 3; ++c) {
      RecordProperty(key + "_mean_" + std::to_string(c), std::to_string(e.mean[c]));
      RecordProperty(key + "_std_error_" + std::to_string(c), std::to_string(e.std_error[c]));
    }
  }
}

// Absorption takes light away: sigma_a > 0 gives strictly less than the environment, and more
// absorption less still. The same rays and streams (common random numbers) for both; each
// difference must exceed 4 standard errors of its own estimate.
TEST(PathTracer, AbsorbingMediumReturnsLessTheMoreItAbsorbs) {
  glm::dvec3 previous(1.0), previous_se(0.0);
  for (const double sigma_a : {1.0, 10.0}) {
    SCOPED_TRACE(sigma_a);
    Scene s = translucentBoxScene(medium(glm::dvec3(200.0), glm::dvec3(sigma_a), 1.3),
                                  glm::dvec3(0.1), glm::vec3(0.0f), 1.0f);
    ASSERT_TRUE(validateScene(s).ok());
    const PathTracer pt(s);
    const Estimate e =
        estimate(pt, PathTracerSettings{}, 20000, 8, [](Rng& rng) { return rayAtBox(rng, 0.04f); });
    EXPECT_TRUE(e.finite);
    for (int c = 0; c < 3; ++c) {
      const double se =
          std::sqrt(e.std_error[c] * e.std_error[c] + previous_se[c] * previous_se[c]);
      EXPECT_LT(e.mean[c], previous[c] - 4.0 * se) << "channel " << c;
    }
    RecordProperty("sigma_a_" + std::to_string(int(sigma_a)) + "_mean", std::to_string(e.mean.x));
    RecordProperty("sigma_a_" + std::to_string(int(sigma_a)) + "_std_error",
                   std::to_string(e.std_error.x));
    previous = e.mean;
    previous_se = e.std_error;
  }
}

// Gauss-Legendre nodes and weights on [0, 1] (Newton's method on P_n, Press et al., Numerical
// Recipes 3rd ed., sec. 4.6.1).
void gaussLegendre01(int n, std::vector<double>& x, std::vector<double>& w) {
  x.assign(size_t(n), 0.0);
  w.assign(size_t(n), 0.0);
  for (int i = 0; i < n; ++i) {
    double z = std::cos(std::numbers::pi * (i + 0.75) / (n + 0.5)), dp = 1.0;
    for (int iter = 0; iter < 100; ++iter) {
      double p0 = 1.0, p1 = 0.0;
      for (int k = 1; k <= n; ++k) {
        const double p2 = p1;
        p1 = p0;
        p0 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p2) / k;
      }
      dp = n * (z * p0 - p1) / (z * z - 1.0);
      const double dz = p0 / dp;
      z -= dz;
      if (std::fabs(dz) < 1e-15) break;
    }
    x[size_t(i)] = 0.5 * (1.0 - z);
    w[size_t(i)] = 1.0 / ((1.0 - z * z) * dp * dp);  // 2 / ((1 - z^2) P'^2), halved for [0, 1]
  }
}

// Chandrasekhar's H-function for isotropic scattering of single-scattering albedo `alpha`
// (Chandrasekhar, Radiative Transfer, 1960, ch. V, eq. 11),
//   H(mu) = 1 / (1 - alpha/2 mu int_0^1 H(mu') / (mu + mu') dmu'),
// by fixed-point iteration from H = 1 (which increases monotonically to the solution) on the
// quadrature nodes. Returns the moments int_0^1 H dmu and int_0^1 H mu dmu.
void hFunctionMoments(double alpha, double& h0, double& h1) {
  std::vector<double> x, w;
  gaussLegendre01(64, x, w);
  const size_t n = x.size();
  std::vector<double> h(n, 1.0), next(n);
  for (int iter = 0; iter < 100000; ++iter) {
    double change = 0.0;
    for (size_t i = 0; i < n; ++i) {
      double integral = 0.0;
      for (size_t j = 0; j < n; ++j) integral += w[j] * h[j] / (x[i] + x[j]);
      next[i] = 1.0 / (1.0 - 0.5 * alpha * x[i] * integral);
      change = std::max(change, std::fabs(next[i] - h[i]));
    }
    h.swap(next);
    if (change < 1e-14) break;
  }
  h0 = h1 = 0.0;
  for (size_t i = 0; i < n; ++i) {
    h0 += w[i] * h[i];
    h1 += w[i] * h[i] * x[i];
  }
}

// The total (bi-hemispherical) albedo of a thick slab under uniform light against the
// semi-infinite medium's, A = 1 - 2 sqrt(1 - alpha) int_0^1 H(mu) mu dmu (Chandrasekhar 1960,
// ch. V; the flux the medium returns of a uniform incident radiance). The slab is index-matched
// (eta = 1: no boundary), sigma_s' = 50 /m: 2 m wide (100 mean free paths) and 1 m thick, at least
// 8.7 diffusion lengths 1 / sigma_tr for alpha 0.99, so light entering the sides or the bottom
// reaches the top centre attenuated by e^-8.7 = 2e-4: far below the tolerance. Camera rays arrive
// at the central 10 cm of the top face from cosine-distributed directions, so their mean radiance
// under an environment of 1 is A. Each sample is about 0 or 1, the standard error about
// sqrt(A (1 - A) / n) = 0.002; the tolerance is the larger of 2% of A and 4 standard errors.
TEST(PathTracer, ThickSlabAlbedoMatchesChandrasekharsHFunction) {
  for (const double alpha : {0.9, 0.99}) {
    SCOPED_TRACE(alpha);
    double h0 = 0.0, h1 = 0.0;
    hFunctionMoments(alpha, h0, h1);
    // The solver's check: int_0^1 H dmu = (2 / alpha) (1 - sqrt(1 - alpha)) (Chandrasekhar 1960,
    // ch. V, eq. 20, the zeroth moment).
    EXPECT_NEAR(h0, 2.0 / alpha * (1.0 - std::sqrt(1.0 - alpha)), 1e-6);
    const double expected = 1.0 - 2.0 * std::sqrt(1.0 - alpha) * h1;

    const double sigma_s = 50.0, sigma_a = sigma_s * (1.0 - alpha) / alpha;
    Scene s = translucentBoxScene(medium(glm::dvec3(sigma_s), glm::dvec3(sigma_a), 1.0),
                                  glm::dvec3(2.0, 1.0, 2.0), glm::vec3(0.0f, -0.5f, 0.0f), 1.0f);
    ASSERT_TRUE(validateScene(s).ok());
    const PathTracer pt(s);
    const Estimate e = estimate(pt, PathTracerSettings{}, 50000, 9, [](Rng& rng) {
      const glm::vec3 target(0.1f * rng.uniform() - 0.05f, 0.0f, 0.1f * rng.uniform() - 0.05f);
      const glm::vec3 l = sampleCosineHemisphere(rng.uniform(), rng.uniform());
      const glm::vec3 up(l.x, l.z, l.y);  // about +y
      return Ray{target + 0.5f * up, 0.0f, -up, 3.4028234e38f};
    });
    EXPECT_TRUE(e.finite);
    const double tolerance = std::max(0.02 * expected, 4.0 * e.std_error.x);
    EXPECT_NEAR(e.mean.x, expected, tolerance);
    const std::string key = alpha == 0.9 ? "alpha_0.9" : "alpha_0.99";
    RecordProperty(key + "_path_tracer", std::to_string(e.mean.x));
    RecordProperty(key + "_std_error", std::to_string(e.std_error.x));
    RecordProperty(key + "_h_function", std::to_string(expected));
  }
}

// A camera ray told not to reflect at the boundary (boundary_reflection_from_camera = false)
// refracts with weight F_t(cos theta): in the furnace, where all light that enters leaves again,
// its radiance is then F_t exactly in expectation, less than 1 by the mean Fresnel reflectance.
// The test computes F_t of each ray's own hit and asserts that the mean of (sample - F_t) is 0
// within 4 of its standard errors.
TEST(PathTracer, NoBoundaryReflectionFromTheCameraShowsOnlyTransmittedLight) {
  const double eta = 1.3;
  Scene s = translucentBoxScene(medium(glm::dvec3(200.0), glm::dvec3(0.0), eta), glm::dvec3(0.1),
                                glm::vec3(0.0f), 1.0f);
  ASSERT_TRUE(validateScene(s).ok());
  const PathTracer pt(s);
  PathTracerSettings settings;
  settings.boundary_reflection_from_camera = false;
  const size_t n = 100000;
  const auto make_ray = [](Rng& rng) { return rayAtBox(rng, 0.04f); };
  const Estimate e = estimate(pt, settings, n, 10, make_ray);
  EXPECT_TRUE(e.finite);
  double sum_ft = 0.0, sum_d = 0.0, sum_d2 = 0.0;
  for (size_t i = 0; i < n; ++i) {
    Rng rng(10, i);
    const Ray ray = make_ray(rng);
    const Hit hit = pt.geometry().engine.intersect(ray);
    ASSERT_TRUE(hit.hit());
    const double cos_i = -glm::dot(pt.geometry().normals[size_t(hit.triangle)], ray.dir);
    const double ft = fresnelTransmittance(eta, cos_i);
    const double d = e.samples[i].x - ft;
    sum_ft += ft;
    sum_d += d;
    sum_d2 += d * d;
  }
  const double mean_ft = sum_ft / double(n), mean_d = sum_d / double(n);
  const double se_d = std::sqrt((sum_d2 / double(n) - mean_d * mean_d) / double(n - 1));
  EXPECT_NEAR(mean_d, 0.0, 4.0 * se_d);
  EXPECT_LT(mean_ft, 0.97);  // the boundary's reflection is really missing
  EXPECT_LT(e.mean.x, 1.0 - 4.0 * e.std_error.x);
  RecordProperty("mean", std::to_string(e.mean.x));
  RecordProperty("std_error", std::to_string(e.std_error.x));
  RecordProperty("mean_f_t", std::to_string(mean_ft));
}

// render() and renderWavefront() give the same image bit for bit with a translucent box (its
// walk advanced one event per wave), an emissive quad, a floor and the environment.
TEST(PathTracer, WavefrontMatchesRenderWithTranslucentMedia) {
  Scene s = translucentBoxScene(medium({300.0, 200.0, 100.0}, {1.0, 2.0, 4.0}, 1.4),
                                glm::dvec3(0.3), glm::vec3(0.0f, 0.15f, 0.0f), 0.2f);
  s.materials.push_back({"floor", glm::vec3(0.6f), glm::vec3(0.0f)});
  s.materials.push_back({"lamp", glm::vec3(0.0f), glm::vec3(5.0f)});
  Mesh floor;
  test::addQuad(floor, {-1, 0, 1}, {2, 0, 0}, {0, 0, -2}, 1);  // faces up
  s.meshes.push_back(floor);
  Mesh lamp;
  test::addQuad(lamp, {-0.2f, 0.8f, -0.2f}, {0.4f, 0, 0}, {0, 0, 0.4f}, 2);  // faces down
  s.meshes.push_back(lamp);
  ASSERT_TRUE(validateScene(s).ok());
  const PathTracer pt(s);
  Camera camera;
  camera.position = glm::vec3(0.3f, 0.5f, 1.2f);
  camera.look_at = glm::vec3(0.0f, 0.15f, 0.0f);
  PathTracerSettings settings;
  settings.width = 20;
  settings.height = 16;
  settings.spp = 8;
  settings.seed = 3;
  const Image reference = pt.render(camera, settings);
  CpuRayQueries cpu(pt.geometry().engine);
  Expected<Image> wave = pt.renderWavefront(camera, settings, cpu);
  ASSERT_TRUE(wave.ok());
  double sum = 0.0;
  for (size_t i = 0; i < reference.pixels.size(); ++i) {
    ASSERT_EQ(wave->pixels[i], reference.pixels[i]) << i;
    sum += double(reference.pixels[i].x);
  }
  EXPECT_GT(sum, 0.0);
}

}  // namespace
}  // namespace penumbra
