// Rays and hits. A single ray is a plain struct; batches are structures of arrays (design doc
// sec. 8.3), which is also the layout of `penumbra trace` files. Their arrays live on large
// pages (core/large_pages.h): a new batch of 1M hits costs no page faults worth counting.
#pragma once

#include "penumbra/core/large_pages.h"

#include <glm/vec3.hpp>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace penumbra {

// The ray o + t d for t in [tmin, tmax]. `dir` need not be unit length; t is in units of |dir|.
struct Ray {
  glm::vec3 origin{0.0f};
  float tmin = 0.0f;
  glm::vec3 dir{0.0f, 0.0f, 1.0f};
  float tmax = 3.4028234e38f;
};

// Closest hit: triangle index (-1 for a miss), distance t, and the barycentric coordinates u, v
// of the triangle's vertices 1 and 2 (the hit point is (1-u-v) p0 + u p1 + v p2).
struct Hit {
  int32_t triangle = -1;
  float t = 0.0f;
  float u = 0.0f;
  float v = 0.0f;

  bool hit() const { return triangle >= 0; }
};

struct RayBatch {
  LargeVector<float> ox, oy, oz, tmin, dx, dy, dz, tmax;

  size_t size() const { return ox.size(); }
  void resize(size_t n) {
    for (auto* v : {&ox, &oy, &oz, &tmin, &dx, &dy, &dz, &tmax}) v->resize(n);
  }
  void set(size_t i, const Ray& r) {
    ox[i] = r.origin.x, oy[i] = r.origin.y, oz[i] = r.origin.z, tmin[i] = r.tmin;
    dx[i] = r.dir.x, dy[i] = r.dir.y, dz[i] = r.dir.z, tmax[i] = r.tmax;
  }
  Ray get(size_t i) const {
    return Ray{{ox[i], oy[i], oz[i]}, tmin[i], {dx[i], dy[i], dz[i]}, tmax[i]};
  }
};

struct HitBatch {
  LargeVector<int32_t> triangle;
  LargeVector<float> t, u, v;

  size_t size() const { return triangle.size(); }
  void resize(size_t n) {
    triangle.resize(n);
    t.resize(n);
    u.resize(n);
    v.resize(n);
  }
  void set(size_t i, const Hit& h) { triangle[i] = h.triangle, t[i] = h.t, u[i] = h.u, v[i] = h.v; }
  Hit get(size_t i) const { return Hit{triangle[i], t[i], u[i], v[i]}; }
};

}  // namespace penumbra
