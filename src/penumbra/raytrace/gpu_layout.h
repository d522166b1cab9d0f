// std430 layouts of the Ray Engine's GPU buffers, defined once here and mirrored in
// shaders/raytrace/layout.glsl.
#pragma once

#include "penumbra/accel/bvh.h"

#include <cstddef>
#include <cstdint>

namespace penumbra {

// The canonical BvhNode is already std430-compatible (vec3 + uint, vec3 + uint): 32 bytes.
static_assert(sizeof(BvhNode) == 32 && offsetof(BvhNode, index) == 12 &&
              offsetof(BvhNode, hi) == 16 && offsetof(BvhNode, count) == 28);

struct GpuTriangle {  // 48 bytes
  float p0[3];
  int32_t id;
  float p1[3];
  float pad1;
  float p2[3];
  float pad2;
};
static_assert(sizeof(GpuTriangle) == 48 && offsetof(GpuTriangle, p1) == 16 &&
              offsetof(GpuTriangle, p2) == 32);

struct GpuRay {  // 32 bytes
  float org[3];
  float tmin;
  float dir[3];
  float tmax;
};
static_assert(sizeof(GpuRay) == 32 && offsetof(GpuRay, dir) == 16);

struct GpuHit {  // 16 bytes
  int32_t triangle;
  float t, u, v;
};
static_assert(sizeof(GpuHit) == 16);

}  // namespace penumbra
