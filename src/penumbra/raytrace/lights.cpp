#include "penumbra/raytrace/lights.h"

#include "penumbra/raytrace/ray_engine.h"

#include <fmt/format.h>
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
  // Point-like lights: the inverse-square cosine law with the intensity towards p.
  const auto point_like = [&](const glm::vec3& position, auto&& intensity_towards) {
    const glm::dvec3 d = glm::dvec3(position) - p;
    const double d2 = glm::dot(d, d);
    if (!(d2 > 0.0)) return;
    s.distance = std::sqrt(d2);
    s.direction = d / s.distance;
    if (glm::dot(ng, s.direction) <= 0.0) return;
    const double cos_s = glm::dot(ns, s.direction);
    if (cos_s <= 0.0) return;
    s.irradiance = intensity_towards(-s.direction) * cos_s / d2;
  };
  std::visit(Overloaded{[&](const DirectionalLight& dl) {
                          s.direction = -glm::normalize(glm::dvec3(dl.direction));
                          s.distance = std::numeric_limits<double>::infinity();
                          if (glm::dot(ng, s.direction) <= 0.0) return;
                          const double cos_s = glm::dot(ns, s.direction);
                          if (cos_s > 0.0) s.irradiance = glm::dvec3(dl.irradiance) * cos_s;
                        },
                        [&](const PointLight& pl) {
                          point_like(pl.position,
                                     [&](const glm::dvec3&) { return glm::dvec3(pl.intensity); });
                        },
                        [&](const SpotLight& sl) {
                          point_like(sl.position, [&](const glm::dvec3& out) {
                            return glm::dvec3(sl.intensity) *
                                   spotFalloff(
                                       sl, glm::dot(glm::normalize(glm::dvec3(sl.direction)), out));
                          });
                        },
                        [&](const LuminaireLight& lu) {
                          // Wallner eq. 15: the LDT's intensity towards the receiver (eq. 13-14
                          // lookup).
                          point_like(lu.position, [&](const glm::dvec3& out) {
                            return glm::dvec3(luminaireIntensity(lu, glm::vec3(out)));
                          });
                        }},
             light);
  return s;
}

GpuLight gpuLight(const Light& light, uint32_t table_offset) {
  GpuLight g{};
  std::visit(Overloaded{[&](const DirectionalLight& dl) {
                          g.type = GpuLightType::kDirectional;
                          copyFloat3(g.direction, glm::normalize(glm::dvec3(dl.direction)));
                          copyFloat3(g.value, glm::dvec3(dl.irradiance));
                        },
                        [&](const SpotLight& sl) {
                          g.type = GpuLightType::kSpot;
                          copyFloat3(g.position, glm::dvec3(sl.position));
                          copyFloat3(g.direction, glm::normalize(glm::dvec3(sl.direction)));
                          copyFloat3(g.value, glm::dvec3(sl.intensity));
                          // scene/light.h spotFalloff's constants.
                          const double cos_outer = std::cos(double(sl.outer_angle));
                          g.cos_outer = float(cos_outer);
                          g.spot_scale = float(spotScale(sl));
                        },
                        [&](const PointLight& pl) {
                          g.type = GpuLightType::kPoint;
                          copyFloat3(g.position, glm::dvec3(pl.position));
                          copyFloat3(g.value, glm::dvec3(pl.intensity));
                        },
                        [&](const LuminaireLight& lu) {
                          g.type = GpuLightType::kLuminaire;
                          for (int c = 0; c < 3; ++c) {
                            g.position[c] = lu.position[c];
                            g.direction[c] = lu.nadir[c];
                            g.value[c] = lu.scale[c];
                            g.c0[c] = lu.c0[c];
                          }
                          g.table = table_offset;
                        }},
             light);
  return g;
}

std::vector<GpuLight> gpuLights(std::span<const Light> lights, std::vector<float>& tables) {
  std::vector<GpuLight> out;
  tables.clear();
  std::vector<const LuminaireDistribution*> seen;
  std::vector<uint32_t> offsets;
  for (const Light& light : lights) {
    uint32_t offset = 0;
    if (const auto* lu = std::get_if<LuminaireLight>(&light)) {
      const LuminaireDistribution* t = lu->distribution.get();
      const auto it = std::find(seen.begin(), seen.end(), t);
      if (it != seen.end()) {
        offset = offsets[size_t(it - seen.begin())];
      } else {
        // Two header floats (the counts, exact in float) and the rows.
        offset = uint32_t(tables.size());
        tables.push_back(float(t->gamma_count));
        tables.push_back(float(t->c_count));
        tables.insert(tables.end(), t->table.begin(), t->table.end());
        seen.push_back(t);
        offsets.push_back(offset);
      }
    }
    out.push_back(gpuLight(light, offset));
  }
  if (tables.empty()) tables.push_back(0.0f);  // a buffer cannot be empty
  return out;
}

glm::dvec3 lightPower(const Light& light, const Bounds3& bounds) {
  return std::visit(
      Overloaded{[&](const PointLight& pl) { return 4.0 * kPi * glm::dvec3(pl.intensity); },
                 [&](const SpotLight& sl) {
                   // 2 pi I integral over x = cos a in [cos outer, 1] of
                   // clamp((x - cos outer) k, 0, 1)^2.
                   const double co = std::cos(double(sl.outer_angle)), k = spotScale(sl);
                   const double t = std::min(1.0 - co, 1.0 / k);
                   const double integral =
                       k * k * t * t * t / 3.0 + std::max(0.0, 1.0 - co - 1.0 / k);
                   return 2.0 * kPi * integral * glm::dvec3(sl.intensity);
                 },
                 [&](const DirectionalLight& dl) {
                   glm::dvec3 centre;
                   double radius = 0.0;
                   boundingSphere(bounds, centre, radius);
                   return kPi * radius * radius * glm::dvec3(dl.irradiance);
                 },
                 [&](const LuminaireLight& lu) { return luminairePower(lu); }},
      light);
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
  return std::visit(
      Overloaded{[&](const PointLight& pl) {
                   ray.origin = pl.position;
                   ray.dir = glm::vec3(uniformSphere(rng));
                   return true;
                 },
                 [&](const SpotLight& sl) {
                   // Uniform within the outer cone, kept with probability fall-off (rejection).
                   const glm::dvec3 axis = glm::normalize(glm::dvec3(sl.direction));
                   glm::dvec3 t, b;
                   frame(axis, t, b);
                   const double co = std::cos(double(sl.outer_angle));
                   for (int attempt = 0; attempt < 1000; ++attempt) {
                     const double x = co + (1.0 - co) * double(rng.uniform());
                     const double phi = 2.0 * kPi * double(rng.uniform());
                     const double r = std::sqrt(std::max(0.0, 1.0 - x * x));
                     if (double(rng.uniform()) > spotFalloff(sl, x)) continue;
                     ray.origin = sl.position;
                     ray.dir = glm::vec3(x * axis + r * std::cos(phi) * t + r * std::sin(phi) * b);
                     return true;
                   }
                   return false;
                 },
                 [&](const DirectionalLight& dl) {
                   glm::dvec3 centre;
                   double radius = 0.0;
                   boundingSphere(bounds, centre, radius);
                   const glm::dvec3 dir = glm::normalize(glm::dvec3(dl.direction));
                   glm::dvec3 t, b;
                   frame(dir, t, b);
                   const double r = radius * std::sqrt(double(rng.uniform()));
                   const double phi = 2.0 * kPi * double(rng.uniform());
                   ray.origin = glm::vec3(centre - dir * (2.0 * radius + 1e-3) +
                                          r * std::cos(phi) * t + r * std::sin(phi) * b);
                   ray.dir = glm::vec3(dir);
                   return true;
                 },
                 [&](const LuminaireLight& lu) {
                   ray.origin = lu.position;
                   ray.dir = sampleLuminaireDirection(lu, [&] { return rng.uniform(); });
                   return true;
                 }},
      light);
}

glm::dvec3 visibleIrradiance(const RayEngine& engine, double lift, std::span<const Light> lights,
                             const glm::dvec3& p, const glm::dvec3& n, uint64_t* rays) {
  glm::dvec3 e(0.0);
  for (const Light& light : lights) {
    const LightSample ls = sampleLight(light, p, n, n);
    if (ls.irradiance == glm::dvec3(0.0)) continue;
    const bool far = ls.distance > 1e30;
    const glm::dvec3 from = p + n * lift;
    const Ray ray{glm::vec3(from), 1e-4f,
                  far ? glm::vec3(ls.direction) : glm::vec3(ls.direction * ls.distance),
                  far ? std::numeric_limits<float>::max() : 1.0f - 1e-4f};
    if (rays) ++*rays;
    if (engine.occluded(ray)) continue;
    e += ls.irradiance;
  }
  return e;
}

std::vector<std::string> gpuLightDefines() {
  const auto define = [](const char* name, GpuLightType type) {
    return fmt::format("{} {}u", name, uint32_t(type));
  };
  return {define("LIGHT_POINT", GpuLightType::kPoint), define("LIGHT_SPOT", GpuLightType::kSpot),
          define("LIGHT_DIRECTIONAL", GpuLightType::kDirectional),
          define("LIGHT_LUMINAIRE", GpuLightType::kLuminaire)};
}

}  // namespace penumbra
