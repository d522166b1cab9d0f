// What the glTF reader (io/gltf/) and the lightmapped writer (io/gltf_lightmapped.h)
// share: a primitive's triangles in the file's order.
#pragma once

#include "penumbra/core/expected.h"

#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra {

// The corners of a primitive's triangles, three per triangle in the file's order, from its vertex
// sequence and mode (4 triangles, 5 strip, 6 fan; glTF 2.0 sec. 3.7.2.1: strip triangle i is
// (v_i, v_{i+1+i%2}, v_{i+2-i%2}), fan triangle i (v_{i+1}, v_{i+2}, v_0), the same triangle as
// (v_0, v_{i+1}, v_{i+2})). A list's last `seq.size() % 3` vertices are left out.
std::vector<uint32_t> gltfTriangleCorners(int mode, const std::vector<uint32_t>& seq);

}  // namespace penumbra
