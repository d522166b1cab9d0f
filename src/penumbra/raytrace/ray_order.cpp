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

bool batchStartsInside(const RayBatch& rays, const Bounds3& bounds) {
  const size_t n = rays.size();
  if (n == 0) return false;
  constexpr size_t kSamples = 256;
  const size_t samples = std::min(n, kSamples);
  size_t inside = 0;
  for (size_t s = 0; s < samples; ++s) {
    const size_t i = s * n / samples;
    inside += rays.ox[i] >= bounds.lo.x && rays.ox[i] <= bounds.hi.x && rays.oy[i] >= bounds.lo.y &&
              rays.oy[i] <= bounds.hi.y && rays.oz[i] >= bounds.lo.z && rays.oz[i] <= bounds.hi.z;
  }
  return 2 * inside > samples;
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
  // Three stable passes of 10 bits over the 30-bit key (bits 32 .. 61), each in parallel: the
  // batch is cut into a fixed number of chunks (so the result does not depend on the thread
  // count), each chunk counts its digits, and every chunk scatters its keys to the offsets its
  // digits start at (digit-major, chunk-minor), which keeps the sort stable.
  constexpr size_t kDigits = 1024;
  const size_t chunks = std::clamp<size_t>(n / 16384, 1, 64);
  const size_t per_chunk = (n + chunks - 1) / chunks;
  std::vector<std::array<uint32_t, kDigits>> offsets(chunks);
  for (int pass = 0; pass < 3; ++pass) {
    const int shift = 32 + 10 * pass;
    parallelRange(chunks, 1, [&](size_t c_begin, size_t c_end) {
      for (size_t c = c_begin; c < c_end; ++c) {
        offsets[c].fill(0);
        const size_t end = std::min(n, (c + 1) * per_chunk);
        for (size_t i = c * per_chunk; i < end; ++i) ++offsets[c][(keyed[i] >> shift) & 1023u];
      }
    });
    uint32_t start = 0;
    for (size_t d = 0; d < kDigits; ++d) {
      for (size_t c = 0; c < chunks; ++c) {
        const uint32_t count = offsets[c][d];
        offsets[c][d] = start;
        start += count;
      }
    }
    parallelRange(chunks, 1, [&](size_t c_begin, size_t c_end) {
      for (size_t c = c_begin; c < c_end; ++c) {
        std::array<uint32_t, kDigits>& at = offsets[c];
        const size_t end = std::min(n, (c + 1) * per_chunk);
        for (size_t i = c * per_chunk; i < end; ++i)
          tmp[at[(keyed[i] >> shift) & 1023u]++] = keyed[i];
      }
    });
    keyed.swap(tmp);
  }
  LargeVector<uint32_t> order(n);
  parallelRange(n, 1 << 16, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) order[i] = uint32_t(keyed[i]);
  });
  return order;
}

}  // namespace penumbra
