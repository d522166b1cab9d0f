#include "penumbra/scene/texture.h"

#include "penumbra/core/parallel.h"

#include <glm/common.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

namespace penumbra {

namespace {

double srgbDecode(double v) {
  return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

const std::array<float, 256>& srgbTable() {
  static const std::array<float, 256> table = [] {
    std::array<float, 256> t{};
    for (int k = 0; k < 256; ++k) t[size_t(k)] = float(srgbDecode(k / 255.0));
    return t;
  }();
  return table;
}

// The 8-bit sRGB code nearest to linear `v` (for the pyramid of an sRGB texture): the table
// inverted by bisection, so decoding the code gives the closest representable value.
uint8_t linearToSrgb8(float v) {
  const std::array<float, 256>& t = srgbTable();
  if (!(v > 0.0f)) return 0;
  if (v >= 1.0f) return 255;
  const auto it = std::lower_bound(t.begin(), t.end(), v);
  const int hi = int(it - t.begin());
  if (hi == 0) return 0;
  return uint8_t(v - t[size_t(hi - 1)] <= t[size_t(hi)] - v ? hi - 1 : hi);
}

int wrapIndex(int i, int n, TextureWrap mode) {
  switch (mode) {
    case TextureWrap::kClampToEdge:
      return std::clamp(i, 0, n - 1);
    case TextureWrap::kMirroredRepeat: {
      const int period = 2 * n;
      int m = i % period;
      if (m < 0) m += period;
      return m < n ? m : period - 1 - m;
    }
    case TextureWrap::kRepeat:
    default: {
      int m = i % n;
      return m < 0 ? m + n : m;
    }
  }
}

// Image coordinate `s` brought into a range where texel arithmetic cannot overflow, without
// changing what it reads: repeat has period 1, mirrored repeat period 2, clamp saturates.
float reduceCoordinate(float s, TextureWrap mode) {
  if (!std::isfinite(s)) return 0.0f;
  switch (mode) {
    case TextureWrap::kClampToEdge:
      return std::clamp(s, -1.0f, 2.0f);
    case TextureWrap::kMirroredRepeat:
      return s - 2.0f * std::floor(0.5f * s);
    case TextureWrap::kRepeat:
    default:
      return s - std::floor(s);
  }
}

}  // namespace

float srgb8ToLinear(uint8_t v) {
  return srgbTable()[v];
}

uint64_t Texture::plannedBytes(int width, int height, bool sixteen_bit) {
  // The pyramid adds at most a third; each texel 4 channels.
  const uint64_t texels = uint64_t(width) * uint64_t(height);
  return (texels + texels / 3 + 64) * 4 * (sixteen_bit ? 2 : 1);
}

size_t Texture::memoryBytes() const {
  size_t bytes = 0;
  for (const TextureLevel& l : levels_) bytes += l.bytes8.size() + 2 * l.texels16.size();
  return bytes;
}

Texture Texture::fromRgba8(std::string source, int width, int height, std::vector<uint8_t> texels8,
                           bool colour, int file_channels) {
  Texture t;
  t.source_ = std::move(source);
  t.encoding_ = colour ? TexelEncoding::kSrgb8 : TexelEncoding::kLinear8;
  t.file_channels_ = file_channels;
  TextureLevel base;
  base.width = width;
  base.height = height;
  base.bytes8 = std::move(texels8);
  t.levels_.push_back(std::move(base));
  t.buildPyramid();
  return t;
}

Texture Texture::fromRgba16(std::string source, int width, int height,
                            std::span<const uint16_t> texels16, bool colour, int file_channels) {
  Texture t;
  t.source_ = std::move(source);
  t.encoding_ = TexelEncoding::kLinear16;
  t.file_channels_ = file_channels;
  TextureLevel base;
  base.width = width;
  base.height = height;
  base.texels16.assign(texels16.begin(), texels16.end());
  if (colour) {
    // Decoded once here: 16-bit linear keeps every step of a 16-bit sRGB file above 2e-5.
    for (size_t i = 0; i < base.texels16.size(); ++i) {
      if (i % 4 == 3) continue;
      base.texels16[i] = uint16_t(std::lround(srgbDecode(base.texels16[i] / 65535.0) * 65535.0));
    }
  }
  t.levels_.push_back(std::move(base));
  t.buildPyramid();
  return t;
}

glm::vec4 Texture::fetch(int k, int x, int y) const {
  const TextureLevel& l = levels_[size_t(k)];
  const size_t i = 4 * (size_t(y) * size_t(l.width) + size_t(x));
  switch (encoding_) {
    case TexelEncoding::kSrgb8: {
      const std::array<float, 256>& t = srgbTable();
      const uint8_t* p = l.bytes8.data() + i;
      return {t[p[0]], t[p[1]], t[p[2]], p[3] * (1.0f / 255.0f)};
    }
    case TexelEncoding::kLinear8: {
      const uint8_t* p = l.bytes8.data() + i;
      return glm::vec4(p[0], p[1], p[2], p[3]) * (1.0f / 255.0f);
    }
    case TexelEncoding::kLinear16:
    default: {
      const uint16_t* p = l.texels16.data() + i;
      return glm::vec4(p[0], p[1], p[2], p[3]) * (1.0f / 65535.0f);
    }
  }
}

void Texture::buildPyramid() {
  // The mean and whether any alpha is below 1, from level 0.
  {
    const TextureLevel& l = levels_[0];
    glm::dvec4 sum(0.0);
    bool alpha = false;
    for (int y = 0; y < l.height; ++y) {
      glm::dvec4 row(0.0);
      for (int x = 0; x < l.width; ++x) {
        const glm::vec4 c = fetch(0, x, y);
        row += glm::dvec4(c);
        alpha = alpha || c.w < 1.0f;
      }
      sum += row;
    }
    mean_ = glm::vec4(sum / (double(l.width) * double(l.height)));
    has_alpha_ = alpha;
  }
  // Each texel of a level weighs the number of level-0 texels under it (along x and y), so that
  // the texels below an odd edge, grouped three to a texel, count as much as the others.
  std::vector<int> weight_x(size_t(levels_[0].width), 1), weight_y(size_t(levels_[0].height), 1);
  while (levels_.back().width > 1 || levels_.back().height > 1) {
    const int k = int(levels_.size()) - 1;
    const TextureLevel& below = levels_.back();
    TextureLevel next;
    next.width = std::max(1, below.width / 2);
    next.height = std::max(1, below.height / 2);
    const size_t n = 4 * size_t(next.width) * size_t(next.height);
    if (encoding_ == TexelEncoding::kLinear16) {
      next.texels16.resize(n);
    } else {
      next.bytes8.resize(n);
    }
    // Texel (x, y) of the next level covers the texels [x0, x1) x [y0, y1) below it: two per
    // axis, three for the last texel next to an odd edge (so every texel below counts once).
    auto span = [](int i, int n_next, int n_below) {
      const int lo = n_next == n_below ? i : 2 * i;
      int hi = n_next == n_below ? i + 1 : 2 * i + 2;
      if (i == n_next - 1) hi = n_below;
      return std::pair<int, int>(lo, hi);
    };
    std::vector<int> next_x(size_t(next.width), 0), next_y(size_t(next.height), 0);
    for (int x = 0; x < next.width; ++x) {
      const auto [x0, x1] = span(x, next.width, below.width);
      for (int xx = x0; xx < x1; ++xx) next_x[size_t(x)] += weight_x[size_t(xx)];
    }
    for (int y = 0; y < next.height; ++y) {
      const auto [y0, y1] = span(y, next.height, below.height);
      for (int yy = y0; yy < y1; ++yy) next_y[size_t(y)] += weight_y[size_t(yy)];
    }
    parallelRange(size_t(next.height), 16, [&](size_t y_begin, size_t y_end) {
      for (int y = int(y_begin); y < int(y_end); ++y) {
        const auto [y0, y1] = span(y, next.height, below.height);
        for (int x = 0; x < next.width; ++x) {
          const auto [x0, x1] = span(x, next.width, below.width);
          glm::vec4 sum(0.0f);
          for (int yy = y0; yy < y1; ++yy) {
            for (int xx = x0; xx < x1; ++xx) {
              sum += float(weight_x[size_t(xx)] * weight_y[size_t(yy)]) * fetch(k, xx, yy);
            }
          }
          const glm::vec4 c = sum / float(next_x[size_t(x)] * next_y[size_t(y)]);
          const size_t i = 4 * (size_t(y) * size_t(next.width) + size_t(x));
          switch (encoding_) {
            case TexelEncoding::kSrgb8:
              for (int ch = 0; ch < 3; ++ch) next.bytes8[i + size_t(ch)] = linearToSrgb8(c[ch]);
              next.bytes8[i + 3] = uint8_t(std::lround(std::clamp(c.w, 0.0f, 1.0f) * 255.0f));
              break;
            case TexelEncoding::kLinear8:
              for (int ch = 0; ch < 4; ++ch) {
                next.bytes8[i + size_t(ch)] =
                    uint8_t(std::lround(std::clamp(c[ch], 0.0f, 1.0f) * 255.0f));
              }
              break;
            case TexelEncoding::kLinear16:
              for (int ch = 0; ch < 4; ++ch) {
                next.texels16[i + size_t(ch)] =
                    uint16_t(std::lround(std::clamp(c[ch], 0.0f, 1.0f) * 65535.0f));
              }
              break;
          }
        }
      }
    });
    weight_x = std::move(next_x);
    weight_y = std::move(next_y);
    levels_.push_back(std::move(next));
  }
}

void TextureBinding::setTransform(glm::vec2 offset, float rotation, glm::vec2 scale) {
  // KHR_texture_transform: T * R * S, R rotating the UVs counter-clockwise as seen with v
  // down: u' = cos u + sin v, v' = -sin u + cos v. This is what Blender's exporter, three.js,
  // Babylon.js and the TextureTransformTest sample agree on; the extension's GLSL listing has the
  // transpose (glTF issue #1563).
  const float c = std::cos(rotation), s = std::sin(rotation);
  row_u = glm::vec3(c * scale.x, s * scale.y, offset.x);
  row_v = glm::vec3(-s * scale.x, c * scale.y, offset.y);
}

glm::vec4 sampleTextureLevel(const Texture& texture, const TextureSampler& sampler, glm::vec2 st,
                             int k) {
  const TextureLevel& l = texture.level(k);
  const float s = reduceCoordinate(st.x, sampler.wrap_s);
  const float t = reduceCoordinate(st.y, sampler.wrap_t);
  const float x = s * float(l.width) - 0.5f, y = t * float(l.height) - 0.5f;
  const float xf = std::floor(x), yf = std::floor(y);
  const int x0 = int(xf), y0 = int(yf);
  const float fx = x - xf, fy = y - yf;
  const int xa = wrapIndex(x0, l.width, sampler.wrap_s);
  const int xb = wrapIndex(x0 + 1, l.width, sampler.wrap_s);
  const int ya = wrapIndex(y0, l.height, sampler.wrap_t);
  const int yb = wrapIndex(y0 + 1, l.height, sampler.wrap_t);
  const glm::vec4 top = glm::mix(texture.fetch(k, xa, ya), texture.fetch(k, xb, ya), fx);
  const glm::vec4 bottom = glm::mix(texture.fetch(k, xa, yb), texture.fetch(k, xb, yb), fx);
  return glm::mix(top, bottom, fy);
}

glm::vec4 sampleTexture(const Texture& texture, const TextureSampler& sampler, glm::vec2 st) {
  if (!sampler.nearest) return sampleTextureLevel(texture, sampler, st, 0);
  const float s = reduceCoordinate(st.x, sampler.wrap_s);
  const float t = reduceCoordinate(st.y, sampler.wrap_t);
  const int x =
      wrapIndex(int(std::floor(s * float(texture.width()))), texture.width(), sampler.wrap_s);
  const int y =
      wrapIndex(int(std::floor(t * float(texture.height()))), texture.height(), sampler.wrap_t);
  return texture.fetch(0, x, y);
}

glm::vec4 sampleTextureTrilinear(const Texture& texture, const TextureSampler& sampler,
                                 glm::vec2 st, float level) {
  const int l0 = std::clamp(int(level), 0, texture.levelCount() - 1);
  const float f = level - float(l0);
  glm::vec4 c = sampleTextureLevel(texture, sampler, st, l0);
  if (f > 0.0f && l0 + 1 < texture.levelCount()) {
    c = glm::mix(c, sampleTextureLevel(texture, sampler, st, l0 + 1), f);
  }
  return c;
}

}  // namespace penumbra
