#include "penumbra/io/ray_file.h"

#include "penumbra/core/file_util.h"

#include <fmt/format.h>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

namespace penumbra {

static_assert(std::endian::native == std::endian::little,
              "ray and hit files are little-endian; a big-endian build needs byte swapping");

namespace {

Status writeBytes(const std::string& path, const std::string& bytes) {
  return writeAtomically(
      path, [&](const std::string& tmp) -> Status { return writeBytesTo(path, tmp, bytes); });
}

}  // namespace

Expected<RayBatch> decodeRays(const std::string& source, const void* values, size_t count) {
  RayBatch rays;
  rays.resize(count);
  const char* bytes = static_cast<const char*>(values);
  for (size_t i = 0; i < count; ++i) {
    float f[8];
    std::memcpy(f, bytes + 32 * i, sizeof f);
    const Ray r{{f[0], f[1], f[2]}, f[3], {f[4], f[5], f[6]}, f[7]};
    const char* problem = nullptr;
    if (!std::isfinite(r.origin.x) || !std::isfinite(r.origin.y) || !std::isfinite(r.origin.z)) {
      problem = "origin is not finite";
    } else if (!std::isfinite(r.dir.x) || !std::isfinite(r.dir.y) || !std::isfinite(r.dir.z)) {
      problem = "direction is not finite";
    } else if (r.dir.x == 0.0f && r.dir.y == 0.0f && r.dir.z == 0.0f) {
      problem = "direction is zero";
    } else if (!std::isfinite(r.tmin)) {
      problem = "tmin is not finite";
    } else if (std::isnan(r.tmax)) {
      problem = "tmax is NaN";
    }
    if (problem) return inputError(source, fmt::format("ray {}", i), problem);
    rays.set(i, r);
  }
  return rays;
}

Expected<RayBatch> readRayFile(const std::string& path) {
  Expected<std::string> bytes = readFile(path);
  if (!bytes) return bytes.error();
  const std::string& b = *bytes;
  constexpr size_t kRayBytes = 8 * sizeof(float);
  if (b.size() % kRayBytes != 0) {
    return inputError(path, fmt::format("byte {}", b.size() - b.size() % kRayBytes),
                      fmt::format("file size {} is not a multiple of 32 bytes (8 float32 per ray: "
                                  "ox oy oz tmin dx dy dz tmax)",
                                  b.size()));
  }
  return decodeRays(path, b.data(), b.size() / kRayBytes);
}

Status writeRayFile(const std::string& path, const RayBatch& rays) {
  std::string bytes(rays.size() * 32, '\0');
  for (size_t i = 0; i < rays.size(); ++i) {
    const Ray r = rays.get(i);
    const float f[8] = {r.origin.x, r.origin.y, r.origin.z, r.tmin,
                        r.dir.x,    r.dir.y,    r.dir.z,    r.tmax};
    std::memcpy(bytes.data() + i * 32, f, 32);
  }
  return writeBytes(path, bytes);
}

Expected<HitBatch> readHitFile(const std::string& path) {
  Expected<std::string> bytes = readFile(path);
  if (!bytes) return bytes.error();
  if (bytes->size() % 16 != 0) {
    return inputError(path, "",
                      fmt::format("file size {} is not a multiple of 16 bytes", bytes->size()));
  }
  HitBatch hits;
  hits.resize(bytes->size() / 16);
  for (size_t i = 0; i < hits.size(); ++i) {
    Hit h;
    std::memcpy(&h.triangle, bytes->data() + i * 16, 4);
    std::memcpy(&h.t, bytes->data() + i * 16 + 4, 4);
    std::memcpy(&h.u, bytes->data() + i * 16 + 8, 4);
    std::memcpy(&h.v, bytes->data() + i * 16 + 12, 4);
    hits.set(i, h);
  }
  return hits;
}

Status writeHitFile(const std::string& path, const HitBatch& hits) {
  std::string bytes(hits.size() * 16, '\0');
  for (size_t i = 0; i < hits.size(); ++i) {
    const Hit h = reportedHit(hits.get(i));
    std::memcpy(bytes.data() + i * 16, &h.triangle, 4);
    std::memcpy(bytes.data() + i * 16 + 4, &h.t, 4);
    std::memcpy(bytes.data() + i * 16 + 8, &h.u, 4);
    std::memcpy(bytes.data() + i * 16 + 12, &h.v, 4);
  }
  return writeBytes(path, bytes);
}

Status writeOcclusionFile(const std::string& path, const std::vector<uint8_t>& occluded) {
  return writeBytes(path, std::string(occluded.begin(), occluded.end()));
}

}  // namespace penumbra
