// The chart atlas: one lightmap layout for every radiosity and subsurface method. The scene's
// faces (geometry/charts.h) are grouped into charts, flattened, scaled to one texel density for
// the whole scene and packed into one texture, so that area, not triangle count, decides where
// texels go: a 2-triangle wall gets the texels its area deserves, and a 69k-triangle scan about
// as many as its area deserves, shared across triangles (the meshed atlas of Carr, Hall, Hart
// 2003, sec. 2.3 and 4.2, with charts of many triangles rather than one).
//
// Layout (texel (x, y) covers [x, x+1] x [y, y+1] in texel units, its centre at (x + 1/2,
// y + 1/2); row 0 is the top of the image and UV (0, 0) its top-left corner, the glTF convention):
//  - Coverage: texel t covers the part of its chart that lies in its square. Texels with
//    positive coverage are `kInside`: they are the elements (level 0 of the hierarchy), each with
//    its exact area in metres^2 (the clipped pieces of the chart's triangles, mapped back to the
//    surface), the area-weighted normal of those pieces, and the point of the pieces nearest
//    their centroid (with its face and barycentrics). The pieces of a chart's elements tile the
//    chart exactly.
//  - Footprint: the texels a bilinear lookup at some point of the chart reads with a non-zero
//    weight, i.e. those whose centre is less than one texel away from the chart along x and
//    along y. Footprints of different charts never overlap, so no lookup mixes two charts'
//    light. Footprint texels without coverage are `kBorder`.
//  - Every footprint texel records a face and barycentrics: the face whose UV triangle holds
//    the texel's centre, or the nearest one, with barycentrics extrapolated linearly, so that a
//    value that is linear over a face and stored at texel centres is reproduced by bilinear
//    lookups in that face.
//  - Packing: charts in order of decreasing height are dropped into the atlas like Tetris
//    pieces, each at the column where its lower outline lands highest given the outline of what
//    is already placed, with `padding` empty texels between footprints; `padding` rounds of
//    dilation then fill those empty texels next to footprints with a copy of a neighbour's face
//    and barycentrics (`kDilated`), for mipmapping and imprecise texture coordinates.
//  - Size: with a texel density, the width is chosen for a near-square result and the height is
//    what the packing needs (both multiples of 4); with a resolution, the largest density whose
//    packing fits a resolution x resolution atlas.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/geometry/asset_charts.h"
#include "penumbra/geometry/charts.h"
#include "penumbra/scene/scene.h"

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

namespace penumbra {

enum class AtlasTexelKind : uint8_t {
  kEmpty,    // no chart: face -1, value 0
  kInside,   // covered by its chart: an element
  kBorder,   // in a chart's footprint (bilinear lookups inside the chart read it), not covered
  kDilated,  // padding filled from a neighbouring texel (copy of its face and barycentrics)
};

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

struct ChartAtlasOptions {
  // Texels per metre. > 0: the charts are scaled with it. <= 0: the largest density whose
  // charts fit a `resolution` x `resolution` atlas.
  double texel_density = 0.0;
  int resolution = 1024;
  int padding = 1;             // empty texels between footprints (and dilation rounds), >= 1
  int max_resolution = 16384;  // atlases wider or higher than this are refused
  ChartOptions charts;
  // --lightmap-uv asset: meshes with a second UV set keep it as their layout
  // (geometry/asset_charts.h); RadiositySurface::build reads it from the scene.
  bool asset_uvs = false;
};

// A chart as placed in the atlas.
struct AtlasChartPlacement {
  glm::ivec2 origin{0};                           // atlas texel of the chart's local texel (0, 0)
  glm::ivec2 size{0};                             // texels of its footprint's bounding box
  uint32_t first_element = 0, element_count = 0;  // its elements, row-major in the chart
};

struct ChartAtlas {
  int width = 0;
  int height = 0;
  double texel_density = 0.0;  // texels per metre
  int padding = 0;
  std::vector<SurfaceFace> faces;              // what was laid out
  ChartSet charts;                             // segmentation, per-face chart and UVs in metres
  std::vector<AtlasChartPlacement> placement;  // per chart
  // Per face corner k of face f at 3 f + k (the triangle's corner order): texel coordinates
  // (continuous, texel (x, y) spans [x, x+1]), and the same as UVs in [0, 1]^2.
  std::vector<glm::dvec2> corner_texel;
  std::vector<glm::vec2> uvs;

  // Per texel, row-major (y * width + x).
  std::vector<int32_t> texel_chart;          // -1 for kEmpty
  std::vector<int32_t> texel_face;           // -1 for kEmpty
  std::vector<glm::vec2> texel_barycentric;  // (w1, w2) in the triangle's corner order
  std::vector<AtlasTexelKind> texel_kind;
  std::vector<int32_t> texel_element;  // kInside: its element, else -1

  // Elements (kInside texels), grouped by chart, within a chart in Morton order of their
  // chart-local texel coordinates (texel - placement.origin).
  std::vector<uint32_t> element_texel;
  std::vector<uint32_t> element_chart;
  std::vector<double> element_area;  // m^2
  // The point of its pieces nearest their area-weighted centroid: on the surface also where the
  // chart bends inside the texel (there the centroid lies off it, inside a convex solid).
  std::vector<glm::dvec3> element_position;
  std::vector<uint32_t> element_face;  // the face of the piece that point lies on
  // The point's barycentrics (w1, w2) on that face's triangle (its corner order).
  std::vector<glm::vec2> element_barycentric;
  std::vector<glm::dvec3> element_normal;  // unit, area-weighted normal of its pieces
  // The faces whose UV triangles overlap the element's texel: element e's are
  // element_faces[element_face_first[e] .. element_face_first[e + 1]).
  std::vector<uint32_t> element_face_first;
  std::vector<uint32_t> element_faces;

  size_t texelIndex(int x, int y) const { return size_t(y) * size_t(width) + size_t(x); }
  // The faces whose UV triangles overlap element e's texel.
  std::span<const uint32_t> elementFaces(size_t e) const {
    return std::span<const uint32_t>(element_faces)
        .subspan(element_face_first[e], element_face_first[e + 1] - element_face_first[e]);
  }
  size_t elementCount() const { return element_texel.size(); }
  size_t chartCount() const { return placement.size(); }
  glm::ivec2 texelOf(size_t element) const {
    return glm::ivec2(int(element_texel[element] % uint32_t(width)),
                      int(element_texel[element] / uint32_t(width)));
  }

  // The pieces of the chart in the atlas rectangle [lo, hi] (inclusive texels; one texel for an
  // element, a block for a cluster): for each face of `candidate_faces` that overlaps it, the
  // face's UV triangle clipped to the rectangle, mapped to the surface (convex polygons of at
  // most 7 corners). Calls piece(face, corners, count). Returns the total area (m^2).
  template <typename Piece>
  double forEachPiece(glm::ivec2 lo, glm::ivec2 hi, std::span<const uint32_t> candidate_faces,
                      std::span<const glm::vec3> positions, std::span<const glm::uvec3> triangles,
                      Piece&& piece) const;
  // The same for element e with its own faces.
  int elementPieces(size_t e, std::span<const glm::vec3> positions,
                    std::span<const glm::uvec3> triangles,
                    std::vector<std::array<glm::dvec3, 8>>& polygons,
                    std::vector<int>& counts) const;
};

// Barycentrics (w1, w2) of p on the triangle (p0, p1, p2), p projected onto its plane; (0, 0)
// for a degenerate triangle.
glm::dvec2 triangleBarycentric(const glm::dvec3& p, const glm::dvec3& p0, const glm::dvec3& p1,
                               const glm::dvec3& p2);

// The point of the convex planar polygon poly[0 .. n) nearest p.
glm::dvec3 closestPointOnConvexPolygon(const glm::dvec3& p, const glm::dvec3* poly, int n);

// The Z-order (Morton) code of (x, y): bits interleaved, x in the even ones.
uint64_t mortonCode(uint32_t x, uint32_t y);

// Bytes a chart atlas of width x height texels takes, `elements` of them occupied.
uint64_t chartAtlasBytes(uint64_t width, uint64_t height, uint64_t elements);

// Builds the atlas of `faces` of the triangles over `positions` (metres); material_ids per
// triangle. Degenerate faces get no texels (their UVs are zero). Fails (input error) when the
// options are out of range, the density asks for an atlas larger than `max_resolution` or one
// that would not fit in memory, or the charts do not fit `resolution`.
// With `asset`, the faces it gives UVs keep them (geometry/asset_charts.h).
Expected<ChartAtlas> buildChartAtlas(std::span<const glm::vec3> positions,
                                     std::span<const glm::uvec3> triangles,
                                     std::span<const uint32_t> material_ids,
                                     std::span<const SurfaceFace> faces,
                                     const ChartAtlasOptions& options,
                                     const AssetLightmapUvs* asset = nullptr);

// The faces of the scene's flattened triangles that carry light: the front of every triangle and
// the back of those whose material is two-sided (Material::two_sided), in triangle order.
std::vector<SurfaceFace> surfaceFaces(const Scene& scene, const FlatTriangles& flat);

// Fills the footprint and padding texels of `image` (the atlas's size) that `known` does not mark
// from the mean of their known 8-neighbours of the same chart, in rounds until none is left
// (Wallner sec. 3.1's gap filling), so that bilinear lookups inside a chart read only its own
// values. `known` is updated.
void fillChartGaps(const ChartAtlas& atlas, Image& image, std::vector<uint8_t>& known);

// The same fill planned once for a fixed `known` and replayed on any image: the texels in the
// order fillChartGaps fills them, each with its sources (for a solver that fills the same texels
// every frame).
struct ChartGapPlan {
  std::vector<uint32_t> texel;   // filled texels, round by round
  std::vector<uint32_t> first;   // texel k's sources: source[first[k] .. first[k + 1])
  std::vector<uint32_t> source;  // texels known before texel k's round
};
ChartGapPlan planChartGaps(const ChartAtlas& atlas, std::vector<uint8_t> known);
void applyChartGaps(const ChartGapPlan& plan, Image& image);

// The summed area of the scene's faces (m^2): a two-sided triangle counts twice.
double faceArea(const Scene& scene);

// Measures of an atlas, for tests, info and docs.
struct ChartAtlasQuality {
  size_t charts = 0;
  size_t elements = 0;        // kInside texels
  double utilisation = 0.0;   // elements / (width * height)
  double max_stretch = 0.0;   // max over faces of s1 / s2
  double mean_stretch = 0.0;  // area-weighted mean of s1 / s2
  size_t planar_charts = 0, conformal_charts = 0;
};
ChartAtlasQuality measureChartAtlas(const ChartAtlas& atlas, std::span<const glm::vec3> positions,
                                    std::span<const glm::uvec3> triangles);

// Clips the triangle (a, b, c) (texel units, either orientation) to the rectangle [lo, hi];
// writes the polygon's corners (at most 7) and returns their count (0: no overlap of positive
// area).
int clipTriangleToRect(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c,
                       const glm::dvec2& lo, const glm::dvec2& hi, glm::dvec2* out);

// Implementation of the template.
template <typename Piece>
double ChartAtlas::forEachPiece(glm::ivec2 lo, glm::ivec2 hi,
                                std::span<const uint32_t> candidate_faces,
                                std::span<const glm::vec3> positions,
                                std::span<const glm::uvec3> triangles, Piece&& piece) const {
  double total = 0.0;
  const glm::dvec2 rlo(lo), rhi(glm::dvec2(hi) + 1.0);
  for (uint32_t f : candidate_faces) {
    const glm::dvec2 t0(corner_texel[3 * size_t(f)]), t1(corner_texel[3 * size_t(f) + 1]),
        t2(corner_texel[3 * size_t(f) + 2]);
    glm::dvec2 poly[8];
    const int n = clipTriangleToRect(t0, t1, t2, rlo, rhi, poly);
    if (n < 3) continue;
    // Barycentric map from texel coordinates to the surface.
    const glm::uvec3 tri = triangles[faces[f].triangle];
    const glm::dvec3 p0(positions[tri.x]), p1(positions[tri.y]), p2(positions[tri.z]);
    const glm::dvec2 e1 = t1 - t0, e2 = t2 - t0;
    const double det = e1.x * e2.y - e1.y * e2.x;
    if (det == 0.0) continue;
    std::array<glm::dvec3, 8> corners;
    for (int k = 0; k < n; ++k) {
      const glm::dvec2 d = poly[k] - t0;
      const double w1 = (d.x * e2.y - d.y * e2.x) / det, w2 = (e1.x * d.y - e1.y * d.x) / det;
      corners[size_t(k)] = p0 + w1 * (p1 - p0) + w2 * (p2 - p0);
    }
    double area = 0.0;
    {
      glm::dvec3 s(0.0);
      for (int k = 1; k + 1 < n; ++k) {
        s += glm::cross(corners[size_t(k)] - corners[0], corners[size_t(k) + 1] - corners[0]);
      }
      area = 0.5 * std::sqrt(s.x * s.x + s.y * s.y + s.z * s.z);
    }
    if (faces[f].back) std::reverse(corners.begin(), corners.begin() + n);
    total += area;
    piece(f, corners, n, area);
  }
  return total;
}

}  // namespace penumbra
