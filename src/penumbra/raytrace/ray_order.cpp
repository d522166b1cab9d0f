#include "penumbra/raytrace/ray_order.h"

#include "penumbra/core/parallel.h"
#include "penumbra/raytrace/cpu_packet.h"

#include <algorithm>
#include <array>

namespace penumbra {

namespace {

// Spreads the low 10 bits of x to every third bit (bits 0, 3, ..., 27).
uint32_t spreadBits(uint32_t x) {
  x &= 0x3ffu;
  x = (x | (x << 16)) & 0x030000ffu;
  x = (x | (x << 8)) & 0x0300f00fu;
  x = (x | (x << 4)) & 0x030c30c3u;
  x = (x | (x << 2)) & 0x09249249u;
  return x;
}

}  // namespace

bool batchIsCoherent(const RayBatch& rays) {
  const size_t groups = rays.size() / kPacketSize;
  if (groups == 0) return false;
  constexpr size_t kSamples = 64;
  size_t eligible = 0, sampled = 0;
  for (size_t s = 0; s < kSamples; ++s) {
    const size_t g = (s * groups) / kSamples;
    if (s > 0 && g == (s - 1) * groups / kSamples) continue;
    ++sampled;
    eligible += packetEligible(rays, g * kPacketSize);
  }
  return 2 * eligible > sampled;
}

LargeVector<uint32_t> coherentRayOrder(const RayBatch& rays, const Bounds3& bounds) {
  const size_t n = rays.size();
  LargeVector<uint64_t> keyed(n), tmp(n);
  const glm::vec3 lo = bounds.lo;
  const glm::vec3 extent = glm::max(bounds.hi - bounds.lo, glm::vec3(1e-30f));
  const glm::vec3 scale = 511.0f / extent;
  parallelRange(n, 4096, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      uint32_t cell[3];
      const float o[3] = {rays.ox[i], rays.oy[i], rays.oz[i]};
      for (int a = 0; a < 3; ++a) {
        const float c = (o[a] - lo[a]) * scale[a];
        cell[a] = uint32_t(std::clamp(c, 0.0f, 511.0f));  // NaN-free: origins are finite
      }
      const uint32_t octant = uint32_t(rays.dx[i] < 0.0f) << 2 | uint32_t(rays.dy[i] < 0.0f) << 1 |
                              uint32_t(rays.dz[i] < 0.0f);
      const uint32_t key =
          octant << 27 | spreadBits(cell[0]) | spreadBits(cell[1]) << 1 | spreadBits(cell[2]) << 2;
      keyed[i] = uint64_t(key) << 32 | uint64_t(i);
    }
  });
  // Three stable passes of 10 bits over the 30-bit key (bits 32 .. 61).
  for (int pass = 0; pass < 3; ++pass) {
    const int shift = 32 + 10 * pass;
    std::array<size_t, 1025> start{};
    for (size_t i = 0; i < n; ++i) ++start[((keyed[i] >> shift) & 1023u) + 1];
    for (size_t b = 1; b < start.size(); ++b) start[b] += start[b - 1];
    for (size_t i = 0; i < n; ++i) tmp[start[(keyed[i] >> shift) & 1023u]++] = keyed[i];
    keyed.swap(tmp);
  }
  LargeVector<uint32_t> order(n);
  parallelRange(n, 1 << 16, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) order[i] = uint32_t(keyed[i]);
  });
  return order;
}

}  // namespace penumbra
