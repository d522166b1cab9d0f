#include "penumbra/radiosity/lights.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

namespace penumbra {

namespace {

constexpr double kPi = std::numbers::pi;

// 1 / (cos inner - cos outer), clamped as the path tracer clamps it.
double spotScale(const SpotLight& s) {
  return 1.0 / std::max(1e-3, std::cos(double(s.inner_angle)) - std::cos(double(s.outer_angle)));
}

double luminance(const glm::dvec3& c) {
  return 0.3 * c.x + 0.59 * c.y + 0.11 * c.z;
}

// Centre and radius of the sphere around the box.
void boundingSphere(const Bounds3& b, glm::dvec3& centre, double& radius) {
  centre = glm::dvec3(b.center());
  radius = 0.5 * glm::length(glm::dvec3(b.extent()));
}

glm::dvec3 uniformSphere(Rng& rng) {
  const double z = 1.0 - 2.0 * double(rng.uniform());
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  const double phi = 2.0 * kPi * double(rng.uniform());
  return glm::dvec3(r * std::cos(phi), r * std::sin(phi), z);
}

// Two unit vectors completing unit n to an orthonormal frame.
void frame(const glm::dvec3& n, glm::dvec3& t, glm::dvec3& b) {
  const glm::dvec3 a = std::abs(n.x) < 0.6 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  t = glm::normalize(glm::cross(a, n));
  b = glm::cross(n, t);
}

void copyFloat3(float* out, const glm::dvec3& v) {
  for (int c = 0; c < 3; ++c) out[c] = float(v[c]);
}

}  // namespace

LightSample sampleLight(const Light& light, const glm::dvec3& p, const glm::dvec3& ng,
                        const glm::dvec3& ns) {
  LightSample s;
  if (const auto* dl = std::get_if<DirectionalLight>(&light)) {
    s.direction = -glm::normalize(glm::dvec3(dl->direction));
    s.distance = std::numeric_limits<double>::infinity();
    if (glm::dot(ng, s.direction) <= 0.0) return s;
    const double cos_s = glm::dot(ns, s.direction);
    if (cos_s > 0.0) s.irradiance = glm::dvec3(dl->irradiance) * cos_s;
    return s;
  }
  const bool spot = std::holds_alternative<SpotLight>(light);
  const glm::dvec3 pos = spot ? glm::dvec3(std::get<SpotLight>(light).position)
                              : glm::dvec3(std::get<PointLight>(light).position);
  const glm::dvec3 d = pos - p;
  const double d2 = glm::dot(d, d);
  if (!(d2 > 0.0)) return s;
  s.distance = std::sqrt(d2);
  s.direction = d / s.distance;
  if (glm::dot(ng, s.direction) <= 0.0) return s;
  const double cos_s = glm::dot(ns, s.direction);
  if (cos_s <= 0.0) return s;
  glm::dvec3 intensity;
  if (spot) {
    const SpotLight& sl = std::get<SpotLight>(light);
    intensity = glm::dvec3(sl.intensity) *
                spotFalloff(sl, glm::dot(glm::normalize(glm::dvec3(sl.direction)), -s.direction));
  } else {
    intensity = glm::dvec3(std::get<PointLight>(light).intensity);
  }
  s.irradiance = intensity * cos_s / d2;
  return s;
}

GpuLight gpuLight(const Light& light) {
  GpuLight g{};
  if (const auto* dl = std::get_if<DirectionalLight>(&light)) {
    g.type = GpuLightType::kDirectional;
    copyFloat3(g.direction, glm::normalize(glm::dvec3(dl->direction)));
    copyFloat3(g.value, glm::dvec3(dl->irradiance));
  } else if (const auto* sl = std::get_if<SpotLight>(&light)) {
    g.type = GpuLightType::kSpot;
    copyFloat3(g.position, glm::dvec3(sl->position));
    copyFloat3(g.direction, glm::normalize(glm::dvec3(sl->direction)));
    copyFloat3(g.value, glm::dvec3(sl->intensity));
    // scene/light.h spotFalloff's constants.
    const double cos_outer = std::cos(double(sl->outer_angle));
    g.cos_outer = float(cos_outer);
    g.spot_scale = float(1.0 / std::max(1e-3, std::cos(double(sl->inner_angle)) - cos_outer));
  } else {
    const PointLight& pl = std::get<PointLight>(light);
    g.type = GpuLightType::kPoint;
    copyFloat3(g.position, glm::dvec3(pl.position));
    copyFloat3(g.value, glm::dvec3(pl.intensity));
  }
  return g;
}

glm::dvec3 lightPower(const Light& light, const Bounds3& bounds) {
  if (const auto* pl = std::get_if<PointLight>(&light)) {
    return 4.0 * kPi * glm::dvec3(pl->intensity);
  }
  if (const auto* sl = std::get_if<SpotLight>(&light)) {
    // 2 pi I integral over x = cos a in [cos outer, 1] of clamp((x - cos outer) k, 0, 1)^2.
    const double co = std::cos(double(sl->outer_angle)), k = spotScale(*sl);
    const double t = std::min(1.0 - co, 1.0 / k);
    const double integral = k * k * t * t * t / 3.0 + std::max(0.0, 1.0 - co - 1.0 / k);
    return 2.0 * kPi * integral * glm::dvec3(sl->intensity);
  }
  const DirectionalLight& dl = std::get<DirectionalLight>(light);
  glm::dvec3 centre;
  double radius = 0.0;
  boundingSphere(bounds, centre, radius);
  return kPi * radius * radius * glm::dvec3(dl.irradiance);
}

bool lightProbeRay(std::span<const Light> lights, const Bounds3& bounds, Rng& rng, Ray& ray) {
  double total = 0.0;
  std::vector<double> power(lights.size());
  for (size_t i = 0; i < lights.size(); ++i) {
    power[i] = luminance(lightPower(lights[i], bounds));
    total += power[i];
  }
  if (!(total > 0.0)) return false;
  double u = double(rng.uniform()) * total;
  size_t i = 0;
  while (i + 1 < lights.size() && u >= power[i]) u -= power[i++];
  const Light& light = lights[i];
  ray.tmin = 0.0f;
  ray.tmax = std::numeric_limits<float>::max();
  if (const auto* pl = std::get_if<PointLight>(&light)) {
    ray.origin = pl->position;
    ray.dir = glm::vec3(uniformSphere(rng));
    return true;
  }
  if (const auto* sl = std::get_if<SpotLight>(&light)) {
    // Uniform within the outer cone, kept with probability fall-off (rejection).
    const glm::dvec3 axis = glm::normalize(glm::dvec3(sl->direction));
    glm::dvec3 t, b;
    frame(axis, t, b);
    const double co = std::cos(double(sl->outer_angle));
    for (int attempt = 0; attempt < 1000; ++attempt) {
      const double x = co + (1.0 - co) * double(rng.uniform());
      const double phi = 2.0 * kPi * double(rng.uniform());
      const double r = std::sqrt(std::max(0.0, 1.0 - x * x));
      if (double(rng.uniform()) > spotFalloff(*sl, x)) continue;
      ray.origin = sl->position;
      ray.dir = glm::vec3(x * axis + r * std::cos(phi) * t + r * std::sin(phi) * b);
      return true;
    }
    return false;
  }
  const DirectionalLight& dl = std::get<DirectionalLight>(light);
  glm::dvec3 centre;
  double radius = 0.0;
  boundingSphere(bounds, centre, radius);
  const glm::dvec3 dir = glm::normalize(glm::dvec3(dl.direction));
  glm::dvec3 t, b;
  frame(dir, t, b);
  const double r = radius * std::sqrt(double(rng.uniform()));
  const double phi = 2.0 * kPi * double(rng.uniform());
  ray.origin = glm::vec3(centre - dir * (2.0 * radius + 1e-3) + r * std::cos(phi) * t +
                         r * std::sin(phi) * b);
  ray.dir = glm::vec3(dir);
  return true;
}

}  // namespace penumbra
