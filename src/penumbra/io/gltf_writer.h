// glTF 2.0 output of a baked solution (the refined element mesh with its per-corner outgoing
// radiance and a lightmap). Conventions (docs/algorithms.md, "Baked output"):
//   - one mesh, one primitive per scene material (each with its own vertices), triangles with
//     counter-clockwise front faces, metres;
//   - POSITION, NORMAL (the element's front face);
//   - _RADIANCE (float VEC3): the exact outgoing radiance B / pi in W m^-2 sr^-1, linear RGB,
//     smooth across elements (values above 1 are normal);
//   - COLOR_0 (float VEC3): min(1, color_0_scale * _RADIANCE) per channel, linear. The glTF 2.0
//     specification (sec. 3.7.2.1) requires every COLOR_0 component to lie in [0, 1], so radiance
//     cannot go there as it is; the scale is in asset.extras.penumbra.color_0_scale;
//   - TEXCOORD_0: the scene's UVs, or a copy of TEXCOORD_1 when the scene has none (attribute
//     sets must be numbered from 0); TEXCOORD_1: the lightmap UVs (three.js `uv1`, Blender's
//     second UV map, an engine's lightmap UV channel);
//   - a material per scene material: base colour black, metallic 0, roughness 1, emissive
//     factor 1 with the tone-mapped lightmap PNG as emissiveTexture on texCoord 1, so a viewer
//     shows the baked light and nothing else; reflectance and emission are kept in the
//     material's extras.penumbra.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/io/baked_mesh.h"
#include "penumbra/scene/material.h"

#include <nlohmann/json.hpp>

#include <span>
#include <string>

namespace penumbra {

struct BakedGltfInfo {
  std::string name;          // mesh and node name
  std::string bin_uri;       // buffer file, relative to the .gltf ("cornell.bin")
  std::string lightmap_uri;  // the PNG the materials reference ("cornell_lightmap.png")
  float color_0_scale = 1.0f;
  nlohmann::json extras = nlohmann::json::object();  // added to asset.extras.penumbra
};

// Writes `gltf_path` and the buffer `info.bin_uri` beside it (plainly: callers that need atomic
// output write into a staging directory and rename). Run-time error when a file cannot be
// written.
Status writeBakedGltf(const std::string& gltf_path, const BakedMesh& mesh,
                      std::span<const Material> materials, const BakedGltfInfo& info);

}  // namespace penumbra
