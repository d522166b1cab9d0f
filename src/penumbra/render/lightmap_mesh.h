// The scene's own triangles as a baked output, for solvers whose elements are lightmap texels
// (progressive radiosity, Wallner sec. 3): every triangle keeps its three corners (not shared
// between triangles, whose charts differ), its lightmap UVs (TEXCOORD_1) and, per corner, the
// lightmap's value there. The lightmap carries the solution; the corner values are its coarse
// per-vertex fallback (glTF COLOR_0) for viewers that ignore the second UV set.
#pragma once

#include "penumbra/core/image.h"
#include "penumbra/geometry/lightmap_atlas.h"
#include "penumbra/render/element_lightmap.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

// `atlas` must have been built over flattenScene(scene)'s triangles and `lightmap` have its size.
// Triangles of zero area are left out. BakedMesh::element holds each output triangle's scene
// triangle (flattenScene order).
BakedMesh buildLightmapMesh(const Scene& scene, const LightmapAtlas& atlas, const Image& lightmap);

}  // namespace penumbra
