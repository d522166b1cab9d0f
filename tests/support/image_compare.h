// Image comparisons of a radiosity view against the reference path tracer, shared by the
// radiosity tests: relative RMS over pixels, and over block averages as the issues state their
// bars (blocks holding a pixel that sees an emitter left out).
#pragma once

#include "penumbra/core/image.h"
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

// The path tracer's image of `scene` from `camera` (w x h, spp samples per pixel, seed 0),
// rendered once per process for each `key` and kept.
const Image& pathTracedReference(const std::string& key, const Scene& scene, const Camera& camera,
                                 int width, int height, int spp);

}  // namespace penumbra::test
