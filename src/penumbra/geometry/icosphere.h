// A sphere as a triangle mesh: the icosahedron with each face split into four `subdivisions`
// times and its vertices pushed onto the unit sphere (20 x 4^subdivisions triangles), wound
// outwards, with the exact normals as shading normals. The JSON scene's "sphere" meshes.
#pragma once

#include "penumbra/scene/mesh.h"

namespace penumbra {

inline constexpr int kMaxSphereSubdivisions = 8;  // 1,310,720 triangles

inline constexpr uint64_t icosphereTriangles(int subdivisions) {
  return uint64_t(20) << (2 * subdivisions);
}

// Unit radius around the origin; subdivisions in [0, kMaxSphereSubdivisions].
Mesh icosphere(int subdivisions);

}  // namespace penumbra
