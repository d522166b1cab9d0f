// The asset's own lightmap UVs as the atlas's charts (`--lightmap-uv asset`): a mesh whose file
// gives it a second UV set (glTF TEXCOORD_1, the lightmap channel of Unity, Unreal, Godot and
// three.js) keeps the layout its artist made.
//
//  - Each such mesh's front faces form one block: its UVs, which must lie in [0, 1]^2 and must
//    not overlap, scaled so that a UV unit spans sqrt(area / UV area) metres, so the block gets
//    the texels its area deserves at the scene's texel density. The packer places it (and may
//    turn it by quarter turns) as one piece beside the generated charts of every other face, so
//    its islands keep their places relative to each other.
//  - Once placed, each island (faces connected by edges whose ends have the same position and
//    the same UV) becomes a chart of its own, so that the hierarchy's clusters, the gap fill and
//    the footprints never mix two islands (geometry/surface_hierarchy.h, chart_atlas.h). An
//    island too small to own a texel at this density (its texels all shared with a bigger
//    island) joins the island it shares them with.
//  - Back faces of two-sided surfaces are charted as every other face (a vertex has one
//    lightmap UV, for its front).
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/geometry/charts.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace penumbra {

struct ChartAtlas;
struct ChartOptions;

// A mesh's own lightmap UVs, per triangle of the mesh an atlas is built over.
struct AssetLightmapUvs {
  std::vector<glm::vec2> corner_uv;     // 3 per triangle, glTF convention (v down)
  std::vector<int32_t> block;           // per triangle: its mesh's block, -1: charted here
  std::vector<std::string> block_name;  // per block: the mesh's name, for messages
  std::vector<uint32_t> block_first;    // per block: its first triangle (messages count from it)
};

// The charts of `faces`: generated ones (buildCharts) for faces outside every block, one chart
// per block (Chart::asset_block) for the rest; face_island receives each face's island (-1 for
// generated charts). Input errors name the mesh: UVs outside [0, 1], a triangle with area whose
// UVs have none, UVs that overlap.
Expected<ChartSet> chartsWithAssetUvs(std::span<const glm::vec3> positions,
                                      std::span<const glm::uvec3> triangles,
                                      std::span<const uint32_t> material_ids,
                                      std::span<const SurfaceFace> faces,
                                      const ChartOptions& options, const AssetLightmapUvs& asset,
                                      std::vector<int32_t>& face_island);

// After placement: each block chart becomes a chart per island (elements reordered by island,
// Morton order kept within each), the other charts renumbered around them.
void splitAssetBlocks(ChartAtlas& atlas, const std::vector<int32_t>& face_island);

}  // namespace penumbra
