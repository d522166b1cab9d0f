// Seams between charts: where a continuous surface is cut into two charts, a bilinear lookup on
// one side of the cut reads other texels than on the other, and the light jumps across the seam
// (godot #90929, playcanvas #4142). Stitching by least squares over the seam edges, as Unity's
// lightmapper does:
//
//  - Seam edges: an edge of two faces of the same side in different charts (ends welded by
//    position) whose normals differ by less than 30 degrees (a crease keeps its jump: the light
//    does change there).
//  - Along each, points every half texel; at each, the bilinear lookup of one side minus that of
//    the other is a residual r_s = sum_i a_si x_i over the texels the two lookups read.
//  - The texels x that the seams read move to minimise sum_s r_s^2 + lambda sum_i (x_i - x0_i)^2,
//    x0 the lightmap as solved: the normal equations (A^T A + lambda I) x = lambda x0, solved per
//    channel by conjugate gradients. lambda = 0.1 keeps each texel near its value and removes
//    most of the jump; texels the seams do not read stay as they are.
#pragma once

#include "penumbra/core/image.h"

#include <cstddef>

namespace penumbra {

struct RadiositySurface;

struct SeamStats {
  size_t edges = 0;          // seam edges stitched
  size_t samples = 0;        // points along them
  size_t texels = 0;         // texels moved
  double jump_before = 0.0;  // largest |lookup A - lookup B| (luminance) before stitching
  double jump_after = 0.0;   // and after
  double rms_before = 0.0;   // RMS of the jumps before and after
  double rms_after = 0.0;
};

// Measures the jumps across the atlas's seams in `image` (its size) without changing it.
SeamStats measureSeams(const RadiositySurface& surface, const Image& image);

// Stitches `image` (the atlas's size, a lightmap of any linear quantity) in place.
SeamStats stitchSeams(const RadiositySurface& surface, Image& image, double lambda = 0.1);

}  // namespace penumbra
