// The order the CPU back end traces a large batch of incoherent rays in: grouped by direction
// octant, then along a Morton curve through their origins, so rays traced one after another
// start in the same part of the scene and walk the same nodes and leaves while those are still
// in the caches. This is the Ray Engine's reorganisation of rays into coherent groups (Carr,
// Hall, Hart 2002, sec. 5.3) as the CPU can afford it: one radix sort of a 30-bit key per ray,
// instead of the ray cache's 5-D tree (which costs more than it saves on the CPU,
// docs/performance.md). Answers do not depend on the order: each ray's hit is its own.
#pragma once

#include "penumbra/accel/bounds.h"
#include "penumbra/kernels/ray.h"

#include <cstdint>
#include <vector>

namespace penumbra {

// Whether the batch already comes in coherent runs (camera rays in scanline order): most of
// 64 sampled aligned groups of eight could travel as packets. Those keep their order.
bool batchIsCoherent(const RayBatch& rays);

// Whether most of 256 sampled rays start inside `bounds` (the scene's). The order below keys on
// the origin, which says where in the tree a ray goes only for rays that start among the
// geometry (bounces, shadow and ambient occlusion rays); rays from outside the scene have their
// origins clamped to the bounds' faces and spread over the whole tree from there.
bool batchStartsInside(const RayBatch& rays, const Bounds3& bounds);

// Indices 0 .. n-1 sorted by (octant of the direction, Morton code of the origin quantised to
// 2^9 cells per axis of `bounds`, clamped); ties keep input order. Parallel key computation,
// then a least-significant-digit radix sort in three passes of 10 bits, each parallel over chunks.
LargeVector<uint32_t> coherentRayOrder(const RayBatch& rays, const Bounds3& bounds);

}  // namespace penumbra
