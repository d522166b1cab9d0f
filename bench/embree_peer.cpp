#include "embree_peer.h"

#include "penumbra/core/parallel.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>

namespace penumbra::bench {

namespace {

// Embree's memory monitor for devices made here: bytes held, allocations minus frees.
bool countBytes(void* counter, ssize_t bytes, bool) {
  *static_cast<std::atomic<int64_t>*>(counter) += int64_t(bytes);
  return true;
}
std::atomic<int64_t> g_device_bytes{0};

Hit hitOf(unsigned geom, unsigned prim, float t, float u, float v) {
  return geom == RTC_INVALID_GEOMETRY_ID ? Hit{-1, INFINITY, 0.0f, 0.0f}
                                         : Hit{int32_t(prim), t, u, v};
}

// The eight rays of packet p (lanes past the end repeat the last ray and are marked invalid).
template <typename Ray8>
void loadPacket(const RayBatch& rays, size_t p, Ray8& r, int* valid) {
  for (int k = 0; k < 8; ++k) {
    const size_t i = p * 8 + size_t(k);
    valid[k] = i < rays.size() ? -1 : 0;
    const size_t j = std::min(i, rays.size() - 1);
    r.org_x[k] = rays.ox[j], r.org_y[k] = rays.oy[j], r.org_z[k] = rays.oz[j];
    r.tnear[k] = rays.tmin[j];
    r.dir_x[k] = rays.dx[j], r.dir_y[k] = rays.dy[j], r.dir_z[k] = rays.dz[j];
    r.tfar[k] = rays.tmax[j];
    r.mask[k] = ~0u, r.flags[k] = 0, r.time[k] = 0.0f;
  }
}

RTCRay loadRay(const RayBatch& rays, size_t i) {
  RTCRay r;
  r.org_x = rays.ox[i], r.org_y = rays.oy[i], r.org_z = rays.oz[i], r.tnear = rays.tmin[i];
  r.dir_x = rays.dx[i], r.dir_y = rays.dy[i], r.dir_z = rays.dz[i], r.tfar = rays.tmax[i];
  r.mask = ~0u, r.flags = 0, r.time = 0.0f;
  return r;
}

}  // namespace

EmbreePeer::EmbreePeer(std::span<const glm::vec3> positions, std::span<const glm::uvec3> triangles,
                       RTCDevice device)
    : device_(device) {
  if (!device_) {
    device_ = rtcNewDevice(nullptr);
    own_device_ = true;
    g_device_bytes = 0;
    rtcSetDeviceMemoryMonitorFunction(device_, countBytes, &g_device_bytes);
  }
  scene_ = rtcNewScene(device_);
  rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_HIGH);
  RTCGeometry g = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0,
                                                        RTC_FORMAT_FLOAT3, 12, positions.size()));
  std::memcpy(v, positions.data(), positions.size() * 12);
  auto* idx = static_cast<unsigned*>(
      rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12, triangles.size()));
  std::memcpy(idx, triangles.data(), triangles.size() * 12);
  rtcCommitGeometry(g);
  rtcAttachGeometry(scene_, g);
  rtcReleaseGeometry(g);
  rtcCommitScene(scene_);
  if (own_device_) {
    bytes_ = g_device_bytes.load() - int64_t(positions.size() * 12 + triangles.size() * 12);
  }
}

EmbreePeer::~EmbreePeer() {
  rtcReleaseScene(scene_);
  if (own_device_) rtcReleaseDevice(device_);
}

void EmbreePeer::intersect1(const RayBatch& rays, HitBatch& hits) const {
  parallelRange(rays.size(), 256, [&](size_t begin, size_t end) {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    for (size_t i = begin; i < end; ++i) {
      RTCRayHit rh;
      rh.ray = loadRay(rays, i);
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rtcIntersect1(scene_, &ctx, &rh);
      hits.set(i, hitOf(rh.hit.geomID, rh.hit.primID, rh.ray.tfar, rh.hit.u, rh.hit.v));
    }
  });
}

void EmbreePeer::intersect8(const RayBatch& rays, HitBatch& hits) const {
  parallelRange((rays.size() + 7) / 8, 32, [&](size_t begin, size_t end) {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    for (size_t p = begin; p < end; ++p) {
      alignas(32) int valid[8];
      alignas(32) RTCRayHit8 rh;
      loadPacket(rays, p, rh.ray, valid);
      for (int k = 0; k < 8; ++k) rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
      rtcIntersect8(valid, scene_, &ctx, &rh);
      for (int k = 0; k < 8 && p * 8 + size_t(k) < rays.size(); ++k) {
        hits.set(p * 8 + size_t(k), hitOf(rh.hit.geomID[k], rh.hit.primID[k], rh.ray.tfar[k],
                                          rh.hit.u[k], rh.hit.v[k]));
      }
    }
  });
}

void EmbreePeer::occluded1(const RayBatch& rays, std::vector<uint8_t>& occluded) const {
  parallelRange(rays.size(), 256, [&](size_t begin, size_t end) {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    for (size_t i = begin; i < end; ++i) {
      RTCRay r = loadRay(rays, i);
      rtcOccluded1(scene_, &ctx, &r);
      occluded[i] = r.tfar < 0.0f ? 1 : 0;
    }
  });
}

void EmbreePeer::occluded8(const RayBatch& rays, std::vector<uint8_t>& occluded) const {
  parallelRange((rays.size() + 7) / 8, 32, [&](size_t begin, size_t end) {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    for (size_t p = begin; p < end; ++p) {
      alignas(32) int valid[8];
      alignas(32) RTCRay8 r;
      loadPacket(rays, p, r, valid);
      rtcOccluded8(valid, scene_, &ctx, &r);
      for (int k = 0; k < 8 && p * 8 + size_t(k) < rays.size(); ++k) {
        occluded[p * 8 + size_t(k)] = r.tfar[k] < 0.0f ? 1 : 0;
      }
    }
  });
}

}  // namespace penumbra::bench
