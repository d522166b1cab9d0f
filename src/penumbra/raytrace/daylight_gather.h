// Daylight through openings (scene/sky.h): the sky, the ground and the outside surfaces seen
// through windows and roof lights, sampled on the openings themselves ("portals"), for
// calculation points and for the radiosity methods' receivers.
//
// The illuminance at x (unit normal n) from the openings is
//   E(x) = sum over openings of  int_A  L_out(w_xy) tau(theta_y) cos(theta_x) cos(theta_y) / r^2
//                                        V(x, y) dA(y),
// where V is the visibility of the opening's point y from x inside, tau the glazing's
// transmittance (scene/sky.h: Opening), and L_out what the ray from y onwards meets: the sky (CIE
// general sky luminance) above the horizon, the ground below it, or an outside surface (its
// radiance from the method's solution). Per triangle t of an opening, with its unoccluded form
// factor F_t in closed form (Lambert's formula, kernels/form_factor.h),
//   E_t = pi F_t sum_i k_i tau_i L_i V_i / sum_i k_i,   k_i = cos(theta_x) cos(theta_y) / r^2,
// over points y_i jittered over the triangle, the rays allocated among the triangles by F_t:
// exact for a uniform sky seen through an unobstructed opening, and free of the noise of
// hemisphere rays that find a small opening by chance.
//
// What reaches x from the sky directly is the sky component (SC), what the ground and outside
// surfaces send the externally reflected component (ERC), both as CIE 171:2006 defines them;
// a gather's hemisphere rays that leave through an opening are then not counted again.
#pragma once

#include "penumbra/core/rng.h"
#include "penumbra/kernels/ray.h"
#include "penumbra/raytrace/ray_engine.h"
#include "penumbra/scene/scene.h"

#include <glm/vec3.hpp>

#include <functional>
#include <optional>
#include <vector>

namespace penumbra {

struct DaylightIrradiance {
  glm::dvec3 sky{0.0};       // from the sky, directly (W m^-2)
  glm::dvec3 external{0.0};  // from the ground and the outside surfaces
};

class OpeningLight {
 public:
  // The radiance along an outside ray that hits the scene's geometry (the method's solution).
  using Outside = std::function<glm::vec3(const Ray& ray, const Hit& hit, Rng& rng)>;

  explicit OpeningLight(const Scene& scene);

  // Whether the scene has a sky and openings to sample it through.
  bool active() const { return sky_.has_value() && !triangles_.empty(); }
  // What a ray leaving the scene along unit `dir` sees: the sky, or the ground below the
  // horizon (the scene must have a sky).
  glm::vec3 skyRadiance(const glm::dvec3& dir) const { return sky_->radiance(dir); }
  // Whether the segment origin + t dir, t in (0, tmax), crosses an opening.
  bool crosses(const Ray& ray, float tmax) const;
  bool hasSky() const { return sky_.has_value(); }
  const std::vector<Opening>& openings() const { return openings_; }

  // The openings as portals for the path tracer's next-event estimation of the sky: a point
  // uniform over their whole area A from (u1, u2), and the density in solid angle of direction
  // `w` (unit) from `x` under that sampling,
  //   p(w) = sum over the openings the ray x + t w crosses of  t^2 / (|cos theta| A),
  // 0 when it crosses none. BSDF sampling finds the same light when its ray escapes; the path
  // tracer weights the two by the power heuristic (Veach 1997, ch. 9). Bitterli et al.'s
  // "Portal-masked environment map sampling" (2015) is the general form; the uniform-area
  // density suits the windows and roof lights of rooms, where BSDF sampling alone finds the
  // sky with a probability of their solid angle.
  glm::dvec3 portalPoint(float u1, float u2) const;
  double portalPdf(const glm::dvec3& x, const glm::dvec3& w) const;

  // The light through the openings at x facing n (planar), or the cylindrical illuminance about
  // the axis n; `samples` points over the openings (jittered, allocated by solid angle), shadow
  // rays from x + lift n. `rays` counts the rays traced.
  DaylightIrradiance irradiance(const RayEngine& engine, const glm::dvec3& x, const glm::dvec3& n,
                                double lift, int samples, bool cylindrical, Rng& rng,
                                const Outside& outside, uint64_t& rays) const;

 private:
  struct Tri {
    glm::dvec3 a, b, c, normal;
    double area = 0.0;
    size_t opening = 0;  // index into openings_
  };
  std::optional<Sky> sky_;
  std::vector<Opening> openings_;
  std::vector<Tri> triangles_;
  std::vector<double> area_cdf_;          // cumulative area over triangles_
  std::vector<glm::dvec3> unit_normals_;  // per opening
};

}  // namespace penumbra
