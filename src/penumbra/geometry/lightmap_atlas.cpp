#include "penumbra/geometry/lightmap_atlas.h"

#include "penumbra/core/check.h"
#include "penumbra/core/memory.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <numeric>

namespace penumbra {

namespace {

// Leg length (texels) of the chart of a triangle of `area` m^2 at `density` texels per metre:
// the chart's area leg^2 / 2 equals area * density^2.
int legFor(double area, double density) {
  const double leg = std::round(std::sqrt(2.0 * area) * density);
  return leg < 1.0 ? 1 : leg > double(1 << 24) ? (1 << 24) : int(leg);
}

// Cell k holds the charts of sorted triangles 2k and 2k + 1 (the larger first).
int cellSize(std::span<const int> sorted_legs, size_t cell) {
  const bool pair = 2 * cell + 1 < sorted_legs.size();
  return sorted_legs[2 * cell] + (pair ? 3 : 2);
}

struct ShelfResult {
  bool fits = false;
  int used_height = 0;
  std::vector<glm::ivec2> cell_origin;
};

// Shelf packing of the cells (non-increasing sizes) into rows of `width` texels.
ShelfResult packShelves(std::span<const int> sorted_legs, int width, int max_height, int gutter,
                        bool keep_origins) {
  ShelfResult r;
  const size_t cells = (sorted_legs.size() + 1) / 2;
  if (keep_origins) r.cell_origin.resize(cells);
  int64_t x = gutter, y = gutter, shelf = 0;
  for (size_t c = 0; c < cells; ++c) {
    const int s = cellSize(sorted_legs, c);
    if (int64_t(s) + 2 * gutter > width) return r;
    if (x + s + gutter > width) {
      y += shelf + gutter;
      x = gutter;
      shelf = 0;
    }
    if (y + s + gutter > max_height) return r;
    if (keep_origins) r.cell_origin[c] = glm::ivec2(int(x), int(y));
    shelf = std::max<int64_t>(shelf, s);
    x += s + gutter;
  }
  r.used_height = int(y + shelf + gutter);
  r.fits = r.used_height <= max_height;
  return r;
}

std::vector<int> legsFor(std::span<const double> sorted_area, double density) {
  std::vector<int> legs(sorted_area.size());
  for (size_t k = 0; k < legs.size(); ++k) legs[k] = legFor(sorted_area[k], density);
  return legs;
}

int nextPowerOfTwo(uint64_t v) {
  return int(std::bit_ceil(std::max<uint64_t>(v, 1)));
}

// Angle at corner k of triangle (p0, p1, p2), radians (0 for a degenerate corner).
double cornerAngle(const glm::dvec3 p[3], int k) {
  const glm::dvec3 a = p[(k + 1) % 3] - p[k], b = p[(k + 2) % 3] - p[k];
  const double la = glm::length(a), lb = glm::length(b);
  if (!(la > 0.0) || !(lb > 0.0)) return 0.0;
  return std::acos(std::clamp(glm::dot(a, b) / (la * lb), -1.0, 1.0));
}

}  // namespace

glm::ivec2 LightmapAtlas::chartTexel(uint32_t triangle, int i, int j) const {
  const AtlasChart& c = charts[triangle];
  return c.corner + c.axis * glm::ivec2(i, j);
}

glm::vec2 LightmapAtlas::chartBarycentric(uint32_t triangle, int i, int j) const {
  const AtlasChart& c = charts[triangle];
  const float inv = 1.0f / float(c.leg);
  float w[3];
  w[c.right] = float(c.leg - i - j) * inv;
  w[(c.right + 1) % 3] = float(i) * inv;
  w[(c.right + 2) % 3] = float(j) * inv;
  return glm::vec2(w[1], w[2]);
}

glm::vec2 LightmapAtlas::uv(uint32_t triangle, glm::vec2 b) const {
  const size_t k = 3 * size_t(triangle);
  return uvs[k] * (1.0f - b.x - b.y) + uvs[k + 1] * b.x + uvs[k + 2] * b.y;
}

uint64_t atlasBytes(uint64_t width, uint64_t height) {
  // Triangle, barycentrics and kind per texel, a copy of the kinds while dilating, and the RGB
  // float image a caller rasterises into it.
  return width * height * (4 + 8 + 1 + 1 + 12);
}

Expected<LightmapAtlas> buildLightmapAtlas(std::span<const glm::vec3> positions,
                                           std::span<const glm::uvec3> triangles,
                                           const AtlasOptions& options) {
  PENUMBRA_CHECK_MSG(options.gutter >= 2, "gutter {}", options.gutter);
  if (triangles.empty()) return inputError("", "", "the lightmap atlas has no triangles");
  const bool by_density = options.texel_density > 0.0;
  if (by_density && !std::isfinite(options.texel_density)) {
    return inputError("", "--texel-density", "must be a finite number of texels per metre");
  }
  if (!by_density && (options.resolution < 8 || options.resolution > options.max_resolution)) {
    return inputError(
        "", "--lightmap-size",
        fmt::format("{} is out of range [8, {}]", options.resolution, options.max_resolution));
  }

  // Triangles sorted by area (largest first, ties by index), so that legs are non-increasing and
  // each pair shares a cell with little waste.
  const size_t n = triangles.size();
  std::vector<double> area(n);
  std::vector<uint32_t> right(n, 0);
  double total_area = 0.0;
  for (size_t t = 0; t < n; ++t) {
    const glm::uvec3 tri = triangles[t];
    PENUMBRA_CHECK_MSG(
        tri.x < positions.size() && tri.y < positions.size() && tri.z < positions.size(),
        "triangle {}", t);
    const glm::dvec3 p[3] = {positions[tri.x], positions[tri.y], positions[tri.z]};
    area[t] = 0.5 * glm::length(glm::cross(p[1] - p[0], p[2] - p[0]));
    if (!std::isfinite(area[t])) area[t] = 0.0;
    total_area += area[t];
    double best = -1.0;
    for (int k = 0; k < 3; ++k) {
      const double angle = cornerAngle(p, k);
      if (angle > best + 1e-12) {
        best = angle;
        right[t] = uint32_t(k);
      }
    }
  }
  std::vector<uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(),
                   [&](uint32_t a, uint32_t b) { return area[a] > area[b]; });
  std::vector<double> sorted_area(n);
  for (size_t k = 0; k < n; ++k) sorted_area[k] = area[order[k]];

  const int gutter = options.gutter;
  double density = options.texel_density;
  std::vector<int> legs;
  int width = 0, height = 0;
  if (by_density) {
    legs = legsFor(sorted_area, density);
    double cell_area = 0.0;
    for (size_t c = 0; c < (n + 1) / 2; ++c) {
      const double s = double(cellSize(legs, c) + gutter);
      cell_area += s * s;
    }
    width = nextPowerOfTwo(uint64_t(std::ceil(std::sqrt(cell_area))));
    for (;; width *= 2) {
      if (width > options.max_resolution) {
        return inputError("", "--texel-density",
                          fmt::format("{} texels per metre needs a lightmap larger than {}x{} "
                                      "for these {} triangles; lower it",
                                      density, options.max_resolution, options.max_resolution, n));
      }
      const ShelfResult r = packShelves(legs, width, width, gutter, false);
      if (r.fits) {
        height = nextPowerOfTwo(uint64_t(r.used_height));
        break;
      }
    }
  } else {
    width = height = options.resolution;
    legs = legsFor(sorted_area, 0.0);
    if (!packShelves(legs, width, height, gutter, false).fits) {
      return inputError("", "--lightmap-size",
                        fmt::format("{} triangles do not fit in a {}x{} lightmap even at one "
                                    "texel each; use a larger size",
                                    n, width, height));
    }
    // The largest density that fits, by bisection. Cells cover about twice the charts' area
    // A d^2, so d = resolution / sqrt(A) does not fit (rounding of small legs aside: then the
    // bracket grows first).
    double lo = 0.0, hi = total_area > 0.0 ? double(width) / std::sqrt(total_area) : 0.0;
    while (hi > 0.0 && hi < 1e12 &&
           packShelves(legsFor(sorted_area, hi), width, height, gutter, false).fits) {
      lo = hi;
      hi *= 2.0;
    }
    for (int it = 0; it < 40 && hi > 0.0; ++it) {
      const double mid = 0.5 * (lo + hi);
      if (packShelves(legsFor(sorted_area, mid), width, height, gutter, false).fits) {
        lo = mid;
      } else {
        hi = mid;
      }
    }
    density = lo;
    legs = legsFor(sorted_area, density);
  }
  PENUMBRA_TRY(checkMemory(atlasBytes(uint64_t(width), uint64_t(height)),
                           fmt::format("a {}x{} lightmap", width, height)));

  LightmapAtlas atlas;
  atlas.width = width;
  atlas.height = height;
  atlas.texel_density = density;
  atlas.gutter = gutter;
  atlas.charts.resize(n);
  const ShelfResult packed = packShelves(legs, width, height, gutter, true);
  PENUMBRA_CHECK_MSG(packed.fits, "{}x{}", width, height);
  for (size_t c = 0; c < packed.cell_origin.size(); ++c) {
    const glm::ivec2 origin = packed.cell_origin[c];
    const int first_leg = legs[2 * c];
    AtlasChart& a = atlas.charts[order[2 * c]];
    a = AtlasChart{origin, glm::ivec2(1, 1), first_leg, right[order[2 * c]]};
    if (2 * c + 1 < n) {
      AtlasChart& b = atlas.charts[order[2 * c + 1]];
      b = AtlasChart{origin + glm::ivec2(first_leg + 2), glm::ivec2(-1, -1), legs[2 * c + 1],
                     right[order[2 * c + 1]]};
    }
  }

  // UVs of the corners: texel centres.
  atlas.uvs.resize(3 * n);
  const glm::vec2 inv_size(1.0f / float(width), 1.0f / float(height));
  for (uint32_t t = 0; t < n; ++t) {
    const AtlasChart& c = atlas.charts[t];
    const glm::ivec2 lattice[3] = {{0, 0}, {c.leg, 0}, {0, c.leg}};
    for (uint32_t k = 0; k < 3; ++k) {
      const glm::ivec2 texel = atlas.chartTexel(t, lattice[k].x, lattice[k].y);
      atlas.uvs[3 * t + (c.right + k) % 3] = (glm::vec2(texel) + 0.5f) * inv_size;
    }
  }

  // Footprints.
  const size_t texels = size_t(width) * size_t(height);
  atlas.texel_triangle.assign(texels, -1);
  atlas.texel_barycentric.assign(texels, glm::vec2(0.0f));
  atlas.texel_kind.assign(texels, AtlasTexelKind::kEmpty);
  auto fill = [&](uint32_t t, int i, int j, AtlasTexelKind kind) {
    const glm::ivec2 p = atlas.chartTexel(t, i, j);
    PENUMBRA_CHECK_MSG(p.x >= 0 && p.y >= 0 && p.x < width && p.y < height,
                       "triangle {} texel ({}, {})", t, p.x, p.y);
    const size_t at = atlas.texelIndex(p.x, p.y);
    // Charts never overlap.
    PENUMBRA_CHECK_MSG(atlas.texel_kind[at] == AtlasTexelKind::kEmpty, "triangle {} texel ({}, {})",
                       t, p.x, p.y);
    atlas.texel_triangle[at] = int32_t(t);
    atlas.texel_barycentric[at] = atlas.chartBarycentric(t, i, j);
    atlas.texel_kind[at] = kind;
  };
  for (uint32_t t = 0; t < n; ++t) {
    const int leg = atlas.charts[t].leg;
    for (int j = 0; j <= leg; ++j) {
      for (int i = 0; i + j <= leg; ++i) fill(t, i, j, AtlasTexelKind::kInside);
    }
    for (int i = 1; i <= leg; ++i) fill(t, i, leg + 1 - i, AtlasTexelKind::kBorder);
  }

  // Dilation into the gutters: `gutter` rounds, each filling the empty texels that have a filled
  // neighbour (edge neighbours first, then diagonal ones, in a fixed order) from the state of the
  // previous round, so the result does not depend on the scan order.
  constexpr int kNeighbours[8][2] = {{-1, 0},  {1, 0},  {0, -1}, {0, 1},
                                     {-1, -1}, {1, -1}, {-1, 1}, {1, 1}};
  std::vector<AtlasTexelKind> before;
  for (int round = 0; round < gutter; ++round) {
    before = atlas.texel_kind;
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        const size_t at = atlas.texelIndex(x, y);
        if (before[at] != AtlasTexelKind::kEmpty) continue;
        for (const auto& d : kNeighbours) {
          const int nx = x + d[0], ny = y + d[1];
          if (nx < 0 || ny < 0 || nx >= width || ny >= height) continue;
          const size_t from = atlas.texelIndex(nx, ny);
          if (before[from] == AtlasTexelKind::kEmpty) continue;
          atlas.texel_triangle[at] = atlas.texel_triangle[from];
          atlas.texel_barycentric[at] = atlas.texel_barycentric[from];
          atlas.texel_kind[at] = AtlasTexelKind::kDilated;
          break;
        }
      }
    }
  }
  return atlas;
}

}  // namespace penumbra
