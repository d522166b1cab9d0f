// Charts of a triangle mesh: connected groups of nearly coplanar faces, each flattened into the
// plane in metres, so that a texture over them (a lightmap, the radiosity elements of every
// method, subsurface samples) has as many texels as the surface's area deserves, independent of
// its tessellation (Carr, Hall, Hart 2003, sec. 4.2: "the number of surface samples is
// independent of both the tessellation of our geometry, and the resolution of the screen").
//
//  - Faces: one side of a triangle. A two-sided surface is two faces, front and back, with
//    opposite normals; they never share a chart (their normals differ by 180 degrees), so each
//    side gets texels of its own.
//  - Segmentation: region growing in the spirit of D-charts (Julius, Kraevoy, Sheffer 2005):
//    seeds in order of decreasing area; a chart takes an adjacent face (sharing an edge, vertices
//    welded by position) of the same material whose normal lies within `max_cone_deg` of the
//    chart's area-weighted mean normal and within `crease_deg` of the neighbour it is reached
//    from, cheapest first: cost = normal deviation + a compactness term (distance from the seed
//    in units of the chart's radius), so flat regions grow as discs and curved ones as patches.
//    Fragments (charts below half the mean chart area, left where a scan is noisy) then join
//    the neighbour of nearest mean normal if the merged chart's normals stay within 70 degrees.
//  - Parameterisation: a chart whose normals all lie within `flat_deg` of its mean is planar and
//    projected orthogonally (isometric); a curved chart takes the least-squares conformal map
//    (Levy, Petitjean, Ray, Maillot 2002, eq. 3-6, with two pinned vertices), rescaled so that
//    its area in the plane equals its area in space; if the conformal map folds (a face with
//    non-positive area), the orthogonal projection onto the mean normal's plane is used instead
//    (no fold, since every normal is within the cone). The in-plane axes follow the chart's
//    principal direction, so its bounding box is tight and wider than high.
//  - Stretch per face: the singular values s1 >= s2 of the map from the face (metres) to the
//    plane (metres); s1 / s2 is 1 for a conformal map and 1 / cos(angle to the mean normal) for
//    the projection.
#pragma once

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace penumbra {

// One side of a triangle (flattenScene order). The back face's normal is the triangle's
// reversed.
struct SurfaceFace {
  uint32_t triangle = 0;
  bool back = false;
};

struct ChartOptions {
  double max_cone_deg = 40.0;  // a face's normal within this of the chart's mean normal
  double crease_deg = 60.0;    // and within this of the neighbouring face it joins through
  double flat_deg = 1.0;       // every normal within this of the mean: a planar chart
  double compactness = 0.05;   // weight of the distance term in the first growth's cost
  int relax_iterations = 3;    // Lloyd iterations of competitive regrowth from central seeds
  // Charts smaller than this fraction of the mean chart area join a neighbour when every face
  // of both stays within merge_cone_deg of their merged mean normal.
  double merge_fraction = 0.5;
  double merge_cone_deg = 70.0;
};

struct Chart {
  std::vector<uint32_t> faces;  // indices into the face list
  glm::dvec3 normal{0.0};       // unit, area-weighted mean of the faces' normals
  double area = 0.0;            // m^2
  bool planar = false;          // orthogonal projection of a flat chart
  bool conformal = false;       // least-squares conformal map (else projection)
  // The asset's own lightmap UVs (geometry/asset_charts.h): the block (mesh) it lays out, or the
  // island once the block is placed; -1 for charts made here. Never split or re-flattened.
  int32_t asset_block = -1;
};

struct ChartSet {
  std::vector<Chart> charts;
  // Per face (the input's order): its chart, -1 for degenerate (zero-area) faces, which get none.
  std::vector<int32_t> face_chart;
  // Per face corner k of face f at 3 f + k, in the triangle's own corner order (for a back face
  // as well): the point in its chart's plane, metres. Zero for degenerate faces. Corners at the
  // same position in the same chart share one value exactly.
  std::vector<glm::dvec2> uv;
  // Per face: max singular value / min singular value of the map to the plane (1 when
  // degenerate).
  std::vector<double> stretch;
};

// Segments and parameterises `faces` of the triangles over `positions`; material_ids per
// triangle (faces of different materials never share a chart).
ChartSet buildCharts(std::span<const glm::vec3> positions, std::span<const glm::uvec3> triangles,
                     std::span<const uint32_t> material_ids, std::span<const SurfaceFace> faces,
                     const ChartOptions& options);

// Splits charts of one mesh's chart set (for charts whose parameterisation overlaps itself).
// The welded vertices and the per-face scratch are made once, so a split costs its chart's
// faces, not the mesh's.
class ChartSplitter {
 public:
  ChartSplitter(std::span<const glm::vec3> positions, std::span<const glm::uvec3> triangles,
                std::span<const SurfaceFace> faces, const ChartOptions& options);
  ~ChartSplitter();
  ChartSplitter(const ChartSplitter&) = delete;
  ChartSplitter& operator=(const ChartSplitter&) = delete;
  // Splits chart c of `set` in two across its principal direction, re-parameterising both
  // halves; the second half is appended. Returns false when the chart has a single face.
  bool split(ChartSet& set, size_t c);

 private:
  struct Scratch;
  std::span<const glm::vec3> positions_;
  std::span<const glm::uvec3> triangles_;
  std::span<const SurfaceFace> faces_;
  ChartOptions options_;
  std::vector<uint32_t> weld_;
  std::unique_ptr<Scratch> scratch_;
};

}  // namespace penumbra
