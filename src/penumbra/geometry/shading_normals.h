// Shading normals per triangle corner, for solvers that treat a tessellated surface as the smooth
// one it approximates (Wallner sec. 3: the shooter's and receivers' normals are interpolated
// across triangles). A mesh's own vertex normals are used where it has them; otherwise they are
// generated: corners at the same position are welded, and a corner's normal is the mean of the
// face normals of the triangles meeting there whose normals lie within `crease_deg` of its own
// triangle's (so a cube keeps its edges and a teapot is smooth), each weighted by the triangle's
// angle at the corner (Thuermer and Wuethrich 1998: area weights would tilt a cylinder's vertex
// normals towards the side whose quads happen to put two triangles at the vertex).
#pragma once

#include "penumbra/scene/scene.h"

#include <glm/vec3.hpp>

#include <vector>

namespace penumbra {

// Unit normals, corner k of triangle t at 3 t + k (flattenScene order), on the front side of
// their triangle (a normal more than 90 degrees from its face normal is replaced by it).
// Degenerate triangles get zero normals.
std::vector<glm::vec3> cornerShadingNormals(const Scene& scene, double crease_deg = 30.0);

}  // namespace penumbra
