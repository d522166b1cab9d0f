#include "penumbra/raytrace/ray_sets.h"

#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/kernels/sampling.h"
#include "penumbra/raytrace/camera_rays.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <limits>

namespace penumbra {

RayBatch cameraRaySet(const Camera& camera, int width, int height) {
  RayBatch batch;
  batch.resize(size_t(width) * size_t(height));
  const CameraRays rays(camera, width, height);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      Ray r = rays.ray(float(x) + 0.5f, float(y) + 0.5f);
      r.tmin = 0.0f;
      r.tmax = std::numeric_limits<float>::infinity();
      batch.set(size_t(y) * size_t(width) + size_t(x), r);
    }
  }
  return batch;
}

RayBatch diffuseRaySet(const std::vector<glm::vec3>& positions,
                       const std::vector<glm::uvec3>& triangles, size_t count, uint64_t seed,
                       float t_min) {
  // Triangles chosen by area through the cumulative distribution.
  std::vector<double> cdf(triangles.size());
  double total = 0.0;
  for (size_t t = 0; t < triangles.size(); ++t) {
    const glm::vec3 p0 = positions[triangles[t].x];
    total += 0.5 * double(glm::length(
                       glm::cross(positions[triangles[t].y] - p0, positions[triangles[t].z] - p0)));
    cdf[t] = total;
  }
  RayBatch batch;
  if (!(total > 0.0)) return batch;
  batch.resize(count);
  // One random stream per block of rays, so that the set does not depend on the thread count.
  constexpr size_t kBlock = 4096;
  parallelRange((count + kBlock - 1) / kBlock, 1, [&](size_t first, size_t last) {
    for (size_t block = first; block < last; ++block) {
      Rng rng(seed, block);
      for (size_t i = block * kBlock; i < std::min(count, (block + 1) * kBlock); ++i) {
        const double pick = double(rng.uniform()) * total;
        const size_t t = std::min<size_t>(
            size_t(std::upper_bound(cdf.begin(), cdf.end(), pick) - cdf.begin()), cdf.size() - 1);
        const glm::vec3 p0 = positions[triangles[t].x], p1 = positions[triangles[t].y],
                        p2 = positions[triangles[t].z];
        const glm::vec3 normal = glm::normalize(glm::cross(p1 - p0, p2 - p0));
        const glm::vec2 b = sampleTriangleBarycentrics(rng.uniform(), rng.uniform());
        const glm::vec3 p = (1.0f - b.x - b.y) * p0 + b.x * p1 + b.y * p2;
        const glm::vec3 d = Frame::fromNormal(rng.uniform() < 0.5f ? normal : -normal)
                                .toWorld(sampleCosineHemisphere(rng.uniform(), rng.uniform()));
        batch.set(i, Ray{p, t_min, d, std::numeric_limits<float>::infinity()});
      }
    }
  });
  return batch;
}

}  // namespace penumbra
