// A lightmap texel's footprint on the surface, and the side of it the texel's value stands for.
//
// A texel covers the part of its chart inside its square (geometry/chart_atlas.h). Where other
// geometry meets the chart inside that square, a wall standing on a floor, a box on the floor,
// the footprint runs under it or through it to the other side: a texel of a dark room's floor
// can reach under a 2 cm wall into the lit room next door. Production bakers handle this by
// moving samples out of geometry (Unity's "texel validity", Bakery's sample adjustment); here:
//   - the anchor: of the element's point and eight points spread over the footprint, the one
//     that sees the most of the others (segments between points lifted off the surface by four
//     times the surface's shadow-ray lift, traced by the Ray Engine), the element's own point
//     unless another sees at least two more (grazing segments on a curved scan do not move it).
//     The element's point (where every radiosity method
//     evaluates the texel) moves there: the texel stands for the side most of its footprint is on;
//   - the visible part: the footprint's points that the anchor sees. The path-traced bake
//     (radiosity/texel_path_trace.h) integrates over it alone, so that the reference never mixes
//     light across a wall either.
// A footprint that no geometry crosses keeps its point (the first four test segments are clear),
// which is every texel away from contacts.
#pragma once

#include <glm/vec3.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace penumbra {

struct RadiositySurface;

// A texel's footprint as triangles (its pieces, fanned), with the cumulative areas to pick one
// by area, the face of each, and the side's normal.
struct TexelFootprint {
  std::vector<std::array<glm::dvec3, 3>> triangles;
  std::vector<double> cumulative;  // running sum of the triangles' areas
  std::vector<uint32_t> face;      // atlas face of each triangle
  glm::dvec3 normal{0.0};

  // A point uniform by area (Osada et al. 2002's square-root warp on the triangle picked by u0);
  // its face in *face when given.
  glm::dvec3 sample(float u0, float u1, float u2, uint32_t* face_out = nullptr) const;
};

TexelFootprint texelFootprint(const RadiositySurface& surface, size_t e);

// How far footprint points are lifted off the surface for the segments between them (m).
double footprintLift(const RadiositySurface& surface);

// Whether the segment between footprint points p and q, both lifted along `normal`, is free.
bool footprintPointsSeeEachOther(const RadiositySurface& surface, const glm::dvec3& p,
                                 const glm::dvec3& q, const glm::dvec3& normal, double lift);

// Moves each element's point (atlas element_position, element_face, element_barycentric) to its
// anchor; returns how many moved. Needs the surface's engine.
size_t anchorElements(RadiositySurface& surface);

}  // namespace penumbra
