// The `penumbra trace` file formats (design doc sec. 4). Rays: little-endian float32, 8 per ray:
// ox oy oz tmin dx dy dz tmax. Hits: 16 bytes per ray: int32 triangle (-1 for a miss), float32
// t, u, v (barycentrics of vertices 1 and 2); a miss has t = +inf and u = v = 0.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/kernels/ray.h"

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace penumbra {

// Reads and validates a ray file: size a multiple of 32 bytes, finite origins and directions,
// non-zero directions, tmin finite, tmax not NaN. Errors name the ray.
Expected<RayBatch> readRayFile(const std::string& path);
// `count` rays in the file's layout (8 float32 each, 32 bytes, no alignment needed), checked as
// readRayFile checks them; errors name `source` and the ray.
Expected<RayBatch> decodeRays(const std::string& source, const void* values, size_t count);
Status writeRayFile(const std::string& path, const RayBatch& rays);

// A hit as the hit file (and the API, penumbra.h) gives it: a miss is triangle -1, t infinite,
// u = v = 0, whatever the back end left in its fields.
inline Hit reportedHit(const Hit& h) {
  return h.hit() ? h : Hit{-1, std::numeric_limits<float>::infinity(), 0.0f, 0.0f};
}

Expected<HitBatch> readHitFile(const std::string& path);
Status writeHitFile(const std::string& path, const HitBatch& hits);
// Occlusion answers (`trace --occlusion`): one byte per ray, 1 when occluded, else 0.
Status writeOcclusionFile(const std::string& path, const std::vector<uint8_t>& occluded);

}  // namespace penumbra
