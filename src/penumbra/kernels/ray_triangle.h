// Ray-triangle intersection: the watertight test of Woop, Benthin and Wald, "Watertight
// Ray/Triangle Intersection", JCGT 2(1), 2013.
//
// Why not the Ray Engine paper's reorganised Moller-Trumbore (Carr et al. 2002, eq. 1-8)?
// That test evaluates each edge function in the triangle's own frame, so two triangles that
// share an edge can both miss a ray through the edge: light leaks through closed meshes (a
// furnace loses energy, a shadow ray slips through a wall). The watertight test shears the
// triangle into the ray's frame first, so the edge functions of a shared edge are evaluated
// on identical inputs and one side always reports the hit; rays through an edge or vertex
// hit (ties resolved by triangle order in the traversal). The GPU kernel of the Ray Engine
// keeps the paper's formulation; its agreement with this test is checked by tests.
#pragma once

#include "penumbra/kernels/ray.h"

#include <glm/vec3.hpp>

#include <cmath>

namespace penumbra {

// Per-ray constants of the watertight test (sec. 3 of Woop et al.): the axis kz where the
// direction is largest, the other two kx, ky (swapped to keep the winding), and the shear.
struct WatertightRay {
  glm::vec3 org;
  int kx, ky, kz;
  float sx, sy, sz;
  float okx, oky, okz;  // org[kx], org[ky], org[kz], for vector kernels
};

inline WatertightRay makeWatertightRay(const glm::vec3& org, const glm::vec3& dir) {
  WatertightRay r;
  r.org = org;
  const glm::vec3 a(std::fabs(dir.x), std::fabs(dir.y), std::fabs(dir.z));
  r.kz = (a.x > a.y) ? (a.x > a.z ? 0 : 2) : (a.y > a.z ? 1 : 2);
  r.kx = r.kz + 1 == 3 ? 0 : r.kz + 1;
  r.ky = r.kx + 1 == 3 ? 0 : r.kx + 1;
  if (dir[r.kz] < 0.0f) {
    const int tmp = r.kx;
    r.kx = r.ky;
    r.ky = tmp;
  }
  // One division; the shear need only be the same for every triangle the ray meets.
  r.sz = 1.0f / dir[r.kz];
  r.sx = dir[r.kx] * r.sz;
  r.sy = dir[r.ky] * r.sz;
  r.okx = org[r.kx];
  r.oky = org[r.ky];
  r.okz = org[r.kz];
  return r;
}

// Intersects triangle (p0, p1, p2) with the ray for t in [tmin, tmax]. On a hit writes t and the
// barycentrics u (of p1), v (of p2) and returns true. Both faces are hit; a degenerate triangle
// never is. Requires a non-zero direction.
inline bool intersectTriangle(const WatertightRay& r, const glm::vec3& p0, const glm::vec3& p1,
                              const glm::vec3& p2, float tmin, float tmax, float& t_out,
                              float& u_out, float& v_out) {
  // Vertices relative to the origin, sheared into the ray's frame (eq. in sec. 3).
  const glm::vec3 a = p0 - r.org, b = p1 - r.org, c = p2 - r.org;
  const float ax = a[r.kx] - r.sx * a[r.kz], ay = a[r.ky] - r.sy * a[r.kz];
  const float bx = b[r.kx] - r.sx * b[r.kz], by = b[r.ky] - r.sy * b[r.kz];
  const float cx = c[r.kx] - r.sx * c[r.kz], cy = c[r.ky] - r.sy * c[r.kz];
  // Scaled barycentrics: edge functions of the three edges.
  float u = cx * by - cy * bx;
  float v = ax * cy - ay * cx;
  float w = bx * ay - by * ax;
  // On an edge in float, recompute in double so the sign is exact (sec. 3.1).
  if (u == 0.0f || v == 0.0f || w == 0.0f) {
    u = float(double(cx) * double(by) - double(cy) * double(bx));
    v = float(double(ax) * double(cy) - double(ay) * double(cx));
    w = float(double(bx) * double(ay) - double(by) * double(ax));
  }
  if ((u < 0.0f || v < 0.0f || w < 0.0f) && (u > 0.0f || v > 0.0f || w > 0.0f)) return false;
  const float det = u + v + w;
  if (det == 0.0f) return false;
  const float az = r.sz * a[r.kz], bz = r.sz * b[r.kz], cz = r.sz * c[r.kz];
  const float t_scaled = u * az + v * bz + w * cz;
  // Compare t_scaled / det against [tmin, tmax] without the division, sign-aware.
  if (det > 0.0f) {
    if (t_scaled < tmin * det || t_scaled > tmax * det) return false;
  } else {
    if (t_scaled > tmin * det || t_scaled < tmax * det) return false;
  }
  const float inv_det = 1.0f / det;
  const float t = t_scaled * inv_det;
  if (!(t >= tmin && t <= tmax)) return false;
  t_out = t;
  u_out = v * inv_det;
  v_out = w * inv_det;
  return true;
}

}  // namespace penumbra
