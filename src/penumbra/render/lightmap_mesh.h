// The scene's own triangles as a baked output, for solvers whose elements are lightmap texels
// (every radiosity method, on the chart atlas): every face keeps its three corners (not shared
// between faces), its lightmap UVs (TEXCOORD_1) and, per corner, the lightmap's value there. A
// two-sided surface's back face is a triangle of its own, wound the other way, so that each side
// shows its own light in a viewer that culls back faces. The lightmap carries the solution; the
// corner values are its coarse per-vertex fallback (glTF COLOR_0) for viewers that ignore the
// second UV set.
#pragma once

#include "penumbra/core/image.h"
#include "penumbra/geometry/chart_atlas.h"
#include "penumbra/io/baked_mesh.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

// `atlas` must have been built over flattenScene(scene)'s triangles and `lightmap` have its size.
// Triangles of zero area are left out. BakedMesh::element holds each output triangle's scene
// triangle (flattenScene order).
BakedMesh buildLightmapMesh(const Scene& scene, const ChartAtlas& atlas, const Image& lightmap);

}  // namespace penumbra
