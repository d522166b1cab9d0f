#include "support/embree_oracle.h"

#include <embree3/rtcore.h>

#include <cstring>
#include <stdexcept>

namespace penumbra::test {

EmbreeScene::EmbreeScene(std::span<const glm::vec3> positions,
                         std::span<const glm::uvec3> triangles, bool robust) {
  device_ = rtcNewDevice(nullptr);
  if (!device_) throw std::runtime_error("rtcNewDevice failed");
  scene_ = rtcNewScene(device_);
  rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_HIGH);
  if (robust) rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_ROBUST);
  RTCGeometry geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), positions.size()));
  for (size_t i = 0; i < positions.size(); ++i) {
    v[3 * i] = positions[i].x, v[3 * i + 1] = positions[i].y, v[3 * i + 2] = positions[i].z;
  }
  auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), triangles.size()));
  std::memcpy(idx, triangles.data(), triangles.size() * sizeof(glm::uvec3));
  rtcCommitGeometry(geom);
  rtcAttachGeometry(scene_, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(scene_);
}

EmbreeScene::~EmbreeScene() {
  if (scene_) rtcReleaseScene(scene_);
  if (device_) rtcReleaseDevice(device_);
}

Hit EmbreeScene::intersect(const Ray& ray) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh;
  rh.ray.org_x = ray.origin.x, rh.ray.org_y = ray.origin.y, rh.ray.org_z = ray.origin.z;
  rh.ray.dir_x = ray.dir.x, rh.ray.dir_y = ray.dir.y, rh.ray.dir_z = ray.dir.z;
  rh.ray.tnear = ray.tmin;
  rh.ray.tfar = ray.tmax;
  rh.ray.mask = 0xFFFFFFFFu;
  rh.ray.flags = 0;
  rh.ray.time = 0.0f;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(scene_, &context, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return Hit{};
  return Hit{int32_t(rh.hit.primID), rh.ray.tfar, rh.hit.u, rh.hit.v};
}

}  // namespace penumbra::test
