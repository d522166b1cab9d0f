// Ray sets for tracing, benchmarks and users trying `penumbra trace`: the primary rays of a
// camera (coherent) and diffuse rays leaving random surface points (incoherent), the two kinds
// of query the Ray Engine paper measures (Carr, Hall, Hart 2002, sec. 7).
#pragma once

#include "penumbra/kernels/ray.h"
#include "penumbra/scene/camera.h"

#include <glm/vec3.hpp>

#include <cstdint>
#include <vector>

namespace penumbra {

// One ray through the centre of every pixel of a width x height image, row by row from the top;
// tmin 0, tmax infinite.
RayBatch cameraRaySet(const Camera& camera, int width, int height);

// `count` rays from points uniform over the surface (triangles chosen by area), leaving either
// side with equal probability, cosine-distributed about that side's normal; tmin `t_min`,
// tmax infinite. Deterministic for a seed. Degenerate triangles (zero area) are never chosen; a
// mesh with no area gives an empty set.
RayBatch diffuseRaySet(const std::vector<glm::vec3>& positions,
                       const std::vector<glm::uvec3>& triangles, size_t count, uint64_t seed,
                       float t_min);

}  // namespace penumbra
