// Image comparisons of a radiosity view against the reference path tracer, shared by the
// radiosity tests: relative RMS over pixels, and over block averages as the issues state their
// bars (blocks holding a pixel that sees an emitter left out).
#pragma once

#include "penumbra/core/image.h"
#include "penumbra/geometry/chart_atlas.h"
#include "penumbra/scene/camera.h"
#include "penumbra/scene/scene.h"

#include <glm/vec3.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace penumbra::test {

double luminance(const glm::vec3& c);

// sqrt(sum |a - b|^2 / sum |b|^2) over the pixels where `mask` is set (RGB).
double relativeRms(const Image& a, const Image& b, const std::vector<uint8_t>& mask);

struct BlockComparison {
  glm::dvec3 mean_ratio{0.0};  // mean of a / mean of b, per channel, over every pixel
  double block_rms = 0.0;      // relative RMS of block means (RGB)
  size_t blocks = 0;           // blocks compared
};
// `block` x `block` pixel blocks; blocks with a pixel of `reference` brighter than
// `emitter_luminance` are left out.
BlockComparison compareBlocks(const Image& image, const Image& reference, int block,
                              double emitter_luminance);

// The path tracer's image of `scene` from `camera` (w x h, spp samples per pixel, `seed`),
// rendered once per process for each (`key`, seed) and kept: tests comparing methods on the same
// view share one reference.
const Image& pathTracedReference(const std::string& key, const Scene& scene, const Camera& camera,
                                 int width, int height, int spp, uint64_t seed = 0);

// The pixels of `reference` that are lit (luminance above 1e-3) and do not see an emitter
// (luminance below `emitter_luminance`: an emitter's outline, where antialiasing decides, would
// swamp every other pixel).
std::vector<uint8_t> litPixels(const Image& reference, double emitter_luminance);

// The camera's view through a lightmap of the chart atlas (bilinear lookups, as a lightmapped
// scene is displayed), `spp` jittered rays per pixel.
Image lightmapView(const FlatTriangles& flat, const ChartAtlas& atlas, const Image& lightmap,
                   const Camera& camera, int width, int height, int spp);

}  // namespace penumbra::test
