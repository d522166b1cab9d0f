// A camera's view of a solution stored in a lightmap atlas (progressive radiosity, Wallner
// sec. 3): primary rays against the scene's triangles, each hit shaded by a bilinear lookup in
// the lightmap at the hit's lightmap UV, as a GPU renders a lightmapped scene.
#pragma once

#include "penumbra/core/image.h"
#include "penumbra/geometry/chart_atlas.h"
#include "penumbra/scene/camera.h"
#include "penumbra/scene/surface_textures.h"

#include <glm/vec3.hpp>

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace penumbra {

struct LightmapViewSettings {
  int width = 512;
  int height = 512;
  int spp = 4;  // jittered primary rays per pixel (antialiasing)
  uint64_t seed = 0;
};

// Bilinear lookup of `lightmap` (the atlas' size) at UV (0, 0 = the top-left corner of the
// image, as ChartAtlas::uvs), clamped to the image.
glm::vec3 sampleBilinear(const Image& lightmap, glm::vec2 uv);

// The radiance a ray sees in a lightmap: its hit read through the face on the side the ray sees
// (bilinear at the hit's lightmap UV), with texture detail when `detail` is given; black where
// that side has no face and for misses.
class LightmapLookup {
 public:
  LightmapLookup(std::span<const glm::vec3> positions, std::span<const glm::uvec3> triangles,
                 const ChartAtlas& atlas, const Image& lightmap,
                 const LightmapDetail* detail = nullptr);
  glm::vec3 radiance(const glm::vec3& ray_dir, int32_t triangle, float u, float v) const;

 private:
  std::span<const glm::vec3> positions_;
  std::span<const glm::uvec3> triangles_;
  const ChartAtlas* atlas_;
  const Image* lightmap_;
  const LightmapDetail* detail_;
  std::vector<int32_t> face_of_;  // the face of each side of each triangle, -1 where none
};

// The same view for one lightmap after another (a solver refining, a scene relit, the camera
// still): the camera's hits are traced once, at construction, and each image costs only the
// lookups. render() gives renderLightmapView's image bit for bit. Keeps spp hits per pixel (24
// bytes each); `positions`, `triangles`, `atlas` and `detail` must outlive it.
inline constexpr uint64_t kLightmapViewBytesPerSample = 24;
class LightmapView {
 public:
  LightmapView(std::span<const glm::vec3> positions, std::span<const glm::uvec3> triangles,
               const ChartAtlas& atlas, const Camera& camera, const LightmapViewSettings& settings,
               const LightmapDetail* detail = nullptr);
  Image render(const Image& lightmap) const;

 private:
  struct Sample {
    glm::vec3 dir;
    int32_t triangle;
    float u, v;
  };
  std::span<const glm::vec3> positions_;
  std::span<const glm::uvec3> triangles_;
  const ChartAtlas* atlas_;
  LightmapViewSettings settings_;
  const LightmapDetail* detail_;
  std::vector<Sample> samples_;  // spp per pixel, in pixel order
  static_assert(sizeof(Sample) == kLightmapViewBytesPerSample);
};

// `triangles` over `positions` are the atlas' triangles (its faces refer to them); a hit reads
// the lightmap through the face on the side the ray sees, and is black where that side has no
// face (the back of a one-sided surface), as are misses. Pixels are independent of the thread
// count.
Image renderLightmapView(std::span<const glm::vec3> positions,
                         std::span<const glm::uvec3> triangles, const ChartAtlas& atlas,
                         const Image& lightmap, const Camera& camera,
                         const LightmapViewSettings& settings,
                         const LightmapDetail* detail = nullptr);

}  // namespace penumbra
