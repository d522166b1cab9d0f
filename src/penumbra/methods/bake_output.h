// What `penumbra bake` writes for an engine (docs/algorithms.md, "Baked output"; the extension
// and the page: docs/web-viewer.md):
//   - the asset output (--gltf asset, the default): the input's glTF with the lightmap attached
//     (io/gltf_lightmapped.h), the lightmap as irradiance E in W m^-2, an EXR (float) and an
//     RGBM PNG (8 bits, linear: E = scale * rgb * a) for the web;
//   - the web viewer (--web DIR): the page and three.js, with bake.json naming the glTF.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/geometry/charts.h"
#include "penumbra/io/gltf_lightmapped.h"
#include "penumbra/scene/scene.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace penumbra {

struct RadiositySurface;

// Irradiance E per atlas texel from a lightmap of outgoing radiance L = B / pi: on each element,
// E = (pi L - emission) / reflectance per channel (B = rho E + emission, the radiosity equation;
// reflectance is the element's mean over its texture, at least 0.02 in the division). A texel
// whose reflectance is below 0.02 in every channel reflects too little for E to be measured
// through it (and shows next to nothing whatever E is): it takes the mean of its neighbours in
// its chart, as the footprint and padding texels do (fillChartGaps).
Image irradianceImage(const RadiositySurface& surface, const Image& radiance);

// 8-bit RGBM: value = scale * (r, g, b) * a with r, g, b, a in [0, 1] (bytes / 255), linear;
// scale is the image's largest channel value (1 for a black image), so nothing clips; a is the
// smallest step of 1/255 that holds the texel's largest channel m = max / scale, so every
// channel is within scale * a / 510, and the brightest within 1/510 + 1/(130050 m) relative:
// 0.4 % for texels above scale / 255, 0.2 % above scale / 5.
struct RgbmImage {
  int width = 0, height = 0;
  double scale = 1.0;
  std::vector<uint8_t> rgba;
};
RgbmImage encodeRgbm(const Image& linear);
Image decodeRgbm(const RgbmImage& rgbm);

// The lightmap UVs of each scene triangle's corners (flattenScene order) from the atlas's faces:
// the front face's, or for a mesh on a two-sided material whose back faces received more light
// (a room whose walls face outwards) the back face's, since a glTF vertex has one lightmap UV.
std::vector<TriangleLightmapUvs> triangleLightmapUvs(const Scene& scene,
                                                     std::span<const SurfaceFace> faces,
                                                     std::span<const glm::vec2> uvs,
                                                     const Image& irradiance);

struct AssetBakeFiles {
  std::string gltf, bin, exr, png;  // paths
  AssetPolicy policy;               // how the scene's glTF file was read (--allow-outside-files)
};

// Writes the asset output: `irradiance` as EXR and RGBM PNG, and the glTF (the scene's own file
// when it is one glTF file, else documentFromScene) referencing them.
Status writeAssetBake(const Scene& scene, const Image& irradiance,
                      std::span<const TriangleLightmapUvs> uvs, const nlohmann::json& extras,
                      const AssetBakeFiles& files);

// The directory the web viewer's files are installed in: $PENUMBRA_WEB_DIR, else
// share/penumbra/web beside the executable's bin/, else the build tree's; an input error
// naming the places looked in when none holds index.html.
Expected<std::string> webViewerDirectory();
// Copies the viewer into `dir` (created through the run's OutputTransaction) with bake.json
// naming the bake's glTF, `bake_files.front()`, by a URI the page can fetch from `dir`: when `dir`
// is another folder than the bake's, the bake's files (`bake_files`: the glTF and the files it
// names) are copied into it, so that a server rooted at `dir` serves everything the page reads.
Status writeWebViewer(const std::string& dir, const std::vector<std::string>& bake_files);

}  // namespace penumbra
