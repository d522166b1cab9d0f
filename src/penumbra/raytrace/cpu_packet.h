// Packets of eight coherent rays traced together through the wide quantised BVH the single rays
// walk (accel/wide_bvh.h), SIMD across the rays (AVX2): each child box of a node and each leaf
// triangle is tested against all eight rays at once (Wald, Slusallek, Benthin, Wagner,
// "Interactive Rendering with Coherent Ray Tracing", EG 2001). Pays off when the rays go the same
// way through the same nodes: camera rays of neighbouring pixels, a bucket of the ray cache (Carr
// et al. 2002, sec. 5.3). The answers are bit-for-bit those of the single-ray path: the same
// watertight arithmetic in the same order.
#pragma once

#include "penumbra/kernels/ray.h"

#include <cstddef>
#include <cstdint>

namespace penumbra {

class RayEngine;

inline constexpr int kPacketSize = 8;

// Whether rays [first, first + 8) can travel as one packet: the same direction octant and the
// same dominant axis (so they share the watertight test's axis permutation), valid intervals,
// and directions within about 25 degrees of the first (else single rays are faster).
bool packetEligible(const RayBatch& rays, size_t first);

// Traces rays [first, first + 8) of `rays` as a packet; writes their hits. Requires
// packetEligible(rays, first) and an AVX2 CPU (cpuHasAvx2()).
void tracePacket(const RayEngine& engine, const RayBatch& rays, size_t first, HitBatch& hits);

}  // namespace penumbra
