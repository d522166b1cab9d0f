// A lightmap atlas of a triangle mesh: every triangle gets its own chart in one texture, so a
// value stored per surface point (radiosity, irradiance, a light map) can be displayed with
// bilinear interpolation (Carr, Hall, Hart 2003, sec. 3.1: resample the per-element radiosity
// into "an atlas of the scene, such as the meshed atlas described in Section 2.3"). Like the
// meshed atlas of Carr and Hart 2002 it is discrete: each triangle is packed individually,
// independently of its neighbours, and seams are avoided by matching the texels a triangle
// fills with the texels bilinear sampling reads (without the multiresolution hierarchy).
//
// Layout (texel (x, y) covers [x, x+1] x [y, y+1], its centre is at (x + 0.5, y + 0.5); row 0 is
// the top of the image, and UV (0, 0) is its top-left corner, the glTF convention):
//  - Chart: an isosceles right triangle whose corners lie on texel centres: the right angle at
//    texel `corner`, the legs `leg` texels long along +-x and +-y (`axis`). The triangle corner
//    with the largest angle goes to the right angle (least distortion). In lattice coordinates
//    (i, j) = axis * (texel - corner), the point of barycentric weights w is
//    i = leg * w[right + 1], j = leg * w[right + 2] (corner indices mod 3).
//  - Size: leg = max(1, round(sqrt(2 A) * density)) for a triangle of area A (m^2), so the chart
//    holds A * density^2 texels: the texel density is texels per metre along a leg.
//  - Texels filled for a chart (its footprint): the `kInside` texels, whose centres lie in the
//    chart (i, j >= 0, i + j <= leg), and the `kBorder` texels just past the hypotenuse
//    (i, j >= 1, i + j = leg + 1). These are exactly the texels a bilinear lookup at a point of
//    the chart reads with a non-zero weight, so footprints that do not overlap never mix.
//  - Pairs: triangles sorted by area are taken two at a time into a square cell of leg + 3 texels
//    (the larger leg): the first at the cell's top-left corner, the second rotated by 180 degrees
//    at its bottom-right corner; a diagonal row of empty texels separates the two footprints.
//  - Cells are shelf-packed with `gutter` (>= 2) empty texels between them and at the atlas
//    border; then `gutter` rounds of dilation fill empty texels next to filled ones with a copy
//    of a neighbour's triangle and barycentrics (`kDilated`), so that mipmapping or slightly
//    imprecise texture coordinates read a chart's own values rather than black.
//
// Every texel knows its triangle and the barycentrics of its centre: exact inside the chart,
// extrapolated linearly (one weight slightly negative) on the border row, so that a value that is
// linear over the triangle, stored at texel centres, is reproduced exactly by bilinear lookups
// anywhere in the triangle. clampBarycentric() gives a point on the triangle for such texels.
#pragma once

#include "penumbra/core/expected.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstdint>
#include <span>
#include <vector>

namespace penumbra {

struct AtlasOptions {
  // Texels per metre. > 0: charts are sized with it and the atlas is the smallest power-of-two
  // width (and power-of-two height) they fit in. <= 0: the atlas is `resolution` x `resolution`
  // and the density is the largest whose charts fit in it.
  double texel_density = 0.0;
  int resolution = 1024;
  int gutter = 2;              // empty texels between cells and at the border, >= 2
  int max_resolution = 16384;  // atlases wider or higher than this are refused
};

enum class AtlasTexelKind : uint8_t {
  kEmpty,    // no triangle: triangle -1, value 0
  kInside,   // centre inside the chart: exact barycentrics
  kBorder,   // the row past the hypotenuse that bilinear lookups inside the chart reach
  kDilated,  // gutter filled from a neighbouring texel (copy of its triangle and barycentrics)
};

struct AtlasChart {
  glm::ivec2 corner{0};  // texel holding the right angle
  glm::ivec2 axis{1};    // direction of the legs along x and y: +1 or -1 each
  int leg = 1;           // texels; the chart has leg + 1 texel centres along each leg
  uint32_t right = 0;    // which triangle corner (0, 1, 2) sits at the right angle
};

struct LightmapAtlas {
  int width = 0;
  int height = 0;
  double texel_density = 0.0;  // texels per metre the charts were sized with
  int gutter = 0;
  std::vector<AtlasChart> charts;  // one per triangle, in input order
  // Lightmap UVs, corner k of triangle t at 3 t + k, in [0, 1]^2 with (0, 0) the top-left corner
  // of the image (glTF convention), pointing at texel centres.
  std::vector<glm::vec2> uvs;
  // Per texel, row-major (y * width + x).
  std::vector<int32_t> texel_triangle;       // -1 for kEmpty
  std::vector<glm::vec2> texel_barycentric;  // (w1, w2): point = (1-w1-w2) p0 + w1 p1 + w2 p2
  std::vector<AtlasTexelKind> texel_kind;

  size_t texelIndex(int x, int y) const { return size_t(y) * size_t(width) + size_t(x); }
  // UV of the point with barycentrics (w1, w2) on triangle t (linear in the barycentrics).
  glm::vec2 uv(uint32_t triangle, glm::vec2 barycentric) const;
  // Lattice point (i, j) of chart t, as a texel, and the barycentrics of its centre (extrapolated
  // outside the chart).
  glm::ivec2 chartTexel(uint32_t triangle, int i, int j) const;
  glm::vec2 chartBarycentric(uint32_t triangle, int i, int j) const;
};

// Bytes an atlas of width x height texels takes (for memory checks before building).
uint64_t atlasBytes(uint64_t width, uint64_t height);

// Builds the atlas of `triangles` over `positions` (metres). Degenerate triangles get the
// smallest chart. Fails (input error) when the options are out of range, when the triangles do
// not fit in `resolution` even at one texel per leg, when the density asks for an atlas larger
// than `max_resolution`, or when it would not fit in memory.
Expected<LightmapAtlas> buildLightmapAtlas(std::span<const glm::vec3> positions,
                                           std::span<const glm::uvec3> triangles,
                                           const AtlasOptions& options);

// The barycentrics of a point of the triangle near (w1, w2): negative weights set to zero and the
// rest renormalised (the identity for points inside).
inline glm::vec2 clampBarycentric(glm::vec2 b) {
  float w0 = 1.0f - b.x - b.y, w1 = b.x, w2 = b.y;
  w0 = w0 > 0.0f ? w0 : 0.0f;
  w1 = w1 > 0.0f ? w1 : 0.0f;
  w2 = w2 > 0.0f ? w2 : 0.0f;
  const float sum = w0 + w1 + w2;
  return sum > 0.0f ? glm::vec2(w1 / sum, w2 / sum) : glm::vec2(0.0f);
}

}  // namespace penumbra
