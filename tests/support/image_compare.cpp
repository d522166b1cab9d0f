#include "support/image_compare.h"

#include "penumbra/raytrace/path_tracer.h"
#include "penumbra/render/lightmap_view.h"

#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <utility>

namespace penumbra::test {

double luminance(const glm::vec3& c) {
  return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
}

double relativeRms(const Image& a, const Image& b, const std::vector<uint8_t>& mask) {
  double num = 0.0, den = 0.0;
  for (size_t i = 0; i < a.pixels.size(); ++i) {
    if (!mask[i]) continue;
    for (int c = 0; c < 3; ++c) {
      const double d = double(a.pixels[i][c]) - double(b.pixels[i][c]);
      num += d * d;
      den += double(b.pixels[i][c]) * double(b.pixels[i][c]);
    }
  }
  return std::sqrt(num / den);
}

BlockComparison compareBlocks(const Image& image, const Image& reference, int block,
                              double emitter_luminance) {
  BlockComparison out;
  glm::dvec3 mean_a(0.0), mean_b(0.0);
  for (size_t i = 0; i < reference.pixels.size(); ++i) {
    mean_a += glm::dvec3(image.pixels[i]);
    mean_b += glm::dvec3(reference.pixels[i]);
  }
  out.mean_ratio = mean_a / mean_b;
  double num = 0.0, den = 0.0;
  const int w = reference.width, h = reference.height;
  for (int by = 0; by < h / block; ++by) {
    for (int bx = 0; bx < w / block; ++bx) {
      glm::dvec3 a(0.0), b(0.0);
      bool emitter = false;
      for (int y = by * block; y < (by + 1) * block; ++y) {
        for (int x = bx * block; x < (bx + 1) * block; ++x) {
          const size_t i = size_t(y) * size_t(w) + size_t(x);
          a += glm::dvec3(image.pixels[i]);
          b += glm::dvec3(reference.pixels[i]);
          emitter = emitter || luminance(reference.pixels[i]) > emitter_luminance;
        }
      }
      if (emitter) continue;
      ++out.blocks;
      for (int c = 0; c < 3; ++c) {
        num += (a[c] - b[c]) * (a[c] - b[c]);
        den += b[c] * b[c];
      }
    }
  }
  out.block_rms = std::sqrt(num / den);
  return out;
}

const Image& pathTracedReference(const std::string& key, const Scene& scene, const Camera& camera,
                                 int width, int height, int spp, uint64_t seed) {
  static std::mutex mutex;
  static std::map<std::pair<std::string, uint64_t>, std::unique_ptr<Image>> cache;
  const std::lock_guard<std::mutex> lock(mutex);
  std::unique_ptr<Image>& slot = cache[{key, seed}];
  if (!slot) {
    const PathTracer tracer(scene);
    PathTracerSettings pt;
    pt.width = width;
    pt.height = height;
    pt.spp = spp;
    pt.seed = seed;
    slot = std::make_unique<Image>(tracer.render(camera, pt));
  }
  return *slot;
}

std::vector<uint8_t> litPixels(const Image& reference, double emitter_luminance) {
  std::vector<uint8_t> lit(reference.pixels.size(), 0);
  for (size_t i = 0; i < lit.size(); ++i) {
    const double l = luminance(reference.pixels[i]);
    lit[i] = l > 1e-3 && l < emitter_luminance;
  }
  return lit;
}

Image lightmapView(const FlatTriangles& flat, const ChartAtlas& atlas, const Image& lightmap,
                   const Camera& camera, int width, int height, int spp) {
  LightmapViewSettings v;
  v.width = width;
  v.height = height;
  v.spp = spp;
  return renderLightmapView(flat.positions, flat.triangles, atlas, lightmap, camera, v);
}

}  // namespace penumbra::test
