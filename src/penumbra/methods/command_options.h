// The options of `penumbra render` and `bake` as the library takes them: what the command line,
// the API, Python and a scene file's "settings" fill in, each value checked against its
// description (methods/registry.h) on the way in.
#pragma once

#include "penumbra/io/tonemap.h"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace penumbra {

// The iteration cap of the iterative methods when none is given, and the largest one taken.
inline constexpr int kIterationCapDefault = 500;
inline constexpr int kIterationCapMax = 1 << 20;
// Stochastic radiosity's: its iterations are cheap, and 1,000 of them after the first shots put
// every 4 x 4 block of the Cornell box and the rooms within 5% (docs/performance.md).
inline constexpr int kStochasticIterationCap = 1000;

// The cap a run of `time_limit` seconds (when set) and `iterations` (when given) gets: a time
// limit alone lifts the default cap, so that it, not the cap, ends the run.
inline int iterationCap(const std::optional<int>& iterations,
                        const std::optional<double>& time_limit = std::nullopt,
                        int default_cap = kIterationCapDefault) {
  if (iterations) return *iterations;
  return time_limit ? kIterationCapMax : default_cap;
}

struct CommonOptions {
  int threads = 0;  // 0 = all cores
  bool quiet = false;
  // --dry-run: check the options, read the inputs, check every output path and the memory the
  // plan needs, then stop before the work; nothing is written or left behind.
  bool dry_run = false;
};

// What `render` and `bake` both take for the lightmap methods (addReceiverOptions and
// addStochasticOptions in cli.cpp bind them for both commands).
struct LightmapMethodOptions {
  // progressive: receivers (Wallner sec. 4): adaptive subdivision at shadow boundaries, the
  // receivers' level (default 0, or 2 with --adaptive), the thresholds b_l and b_u, the finest
  // level and the minimum share of the contrast test (radiosity/progressive_receivers.h).
  bool adaptive = false;
  std::optional<int> receiver_level;
  std::vector<double> boundary;
  int finest_level = 0;
  std::optional<double> min_share;
  // --method stochastic (Barsi and Jakab): a time limit (seconds; the iteration cap still
  // applies), independent shooters per iteration and the emitters shot deterministically first
  // (StochasticOptions::first_shots).
  std::optional<double> time_limit;
  int shooters = 1;
  int first_shots = 32;  // kStochasticFirstShots (radiosity/stochastic.h)
  // The options the caller or the scene's "settings" set (names as on the command line, without
  // dashes): resuming, each option the checkpoint fixes is compared with these, never overridden
  // in silence.
  std::vector<std::string> given;
};

// How `render` and `bake` read their scene (io/scene_io.h: SceneLoadOptions) and what they add to
// it (methods/scene_inputs.h): its unit, and light for a scene that brings none.
struct SceneInputOptions {
  bool allow_outside_files = false;       // files an asset names may lie outside its folder
  int max_texture_size = 8192;            // the largest side a texture keeps (io/image_decode.h)
  std::optional<int> gltf_scene;          // a glTF file's scene other than its own `scene`
  std::optional<double> scale;            // metres per unit of the scene's files
  std::string sky;                        // overcast, uniform, clear or sunny: a CIE sky
  std::optional<double> sky_illuminance;  // its horizontal illuminance, lx (default 10,000)
  std::vector<double> environment;        // a uniform environment's radiance, RGB W m^-2 sr^-1
};

struct RenderOptions : LightmapMethodOptions, SceneInputOptions {
  std::string scene = "cornell";
  std::string method = "pathtrace";
  std::string device = "auto";
  std::vector<std::string> outputs;  // -o, may repeat: one render, several files
  std::string stats;
  std::optional<int> width, height, spp, max_depth;
  std::optional<uint64_t> seed;
  std::optional<std::string> sampler;  // pathtrace: sobol (default) or independent
  ToneMapSettings tonemap;
  // --method matrix (Carr, Hall, Hart 2003, sec. 3).
  std::optional<std::string> solver;  // jacobi or gauss-seidel (default: the device's own)
  // Matrix: elements (default kMatrixDefaultElements); progressive: lightmap texels (about; default
  // kProgressiveDefaultElements).
  std::optional<uint32_t> elements;
  // Iteration cap (progressive: shooters); unset: kIterationCapDefault, or for stochastic
  // radiosity with a time limit no cap but the largest --iterations takes.
  std::optional<int> iterations;
  // matrix: mean squared residual of MB - E, (W m^-2)^2 (default 1e-6); progressive: unshot
  // fraction of the emitted power (default 1e-3).
  std::optional<double> tolerance;
  std::string precision = "fp32";
  // Matrix: shadow rays per cluster pair that exchanges a noticeable share (default
  // FormFactorOptions::rays).
  std::optional<int> ff_rays;
  int relight_frames = 0;  // > 1: a sequence of relit frames from one set of form factors
  std::string shading = "smooth";
  // --method progressive (Wallner): lightmap texels per metre (overrides --elements), the
  // checkpoint to continue from, and where Ctrl-C writes one (default: the first output with
  // the extension .checkpoint).
  std::optional<double> texel_density;
  std::string resume;
  std::string checkpoint;
  bool keep_checkpoint = false;  // keep --resume's file after the run completes
  // progressive: top-level points per shooter (radiosity/progressive.h: hierarchical), and normals
  // (interpolated or triangle).
  int shooter_points = 16;
  std::string normals = "interpolated";
  // --method sss (Carr, Hall, Hart 2003, sec. 4): the atlas size (default kSssDefaultAtlas),
  // links per texel (adaptive) or a hierarchy level for the non-adaptive scheme, and frames of
  // a light orbit.
  std::optional<int> lightmap_size;
  std::optional<int> links;  // default SssLinkOptions::links
  int links_level = -1;
  int frames = 0;
  bool no_cache = false;    // sss: build the links even when the cache holds them
  bool no_shadows = false;  // sss: pass 1 without shadow rays (the paper's lighting)
  // --method lpv (Børlum et al. 2011): grid cells along each object's longest side, propagation
  // steps, steps left out of the accumulation, injection texels per side of each light's map.
  std::optional<int> grid, steps, skip_steps, rsm_resolution, surface_samples, surface_rays;
  // Lighting design (render/illuminance.h, methods/illuminance_output.h): images of lux instead of
  // radiance, false colour with a legend, and a work plane's grid of calculation points.
  std::string output_quantity = "radiance";  // or illuminance
  bool false_colour = false;
  std::optional<double> lux_max;
  std::optional<double> work_plane;  // height above the scene's lowest point, m
  std::string grid_surface;          // or points on the mesh of this name
  std::optional<double> grid_spacing, grid_margin;
  std::string grid_csv;
  std::vector<std::string> calc_files;    // --calc: calculation objects (JSON)
  std::vector<std::string> points_files;  // --points: calculation points (CSV or JSON)
  std::string report_dir;                 // --report: a CSV, JSON and picture per object
  // Hemisphere rays per calculation point; none: as many as a budget of 4 million a calculation
  // object allows, 256 to 65,536 (render/illuminance.h: autoIlluminanceRays). Per pixel: a
  // quarter of it, 64 by default.
  std::optional<int> illuminance_rays;
  // --method whitted and photons (raytrace/whitted.h, photon_map.h): shadow rays per diffuse
  // vertex to the emissive triangles and the environment; photons: the global and caustic photon
  // counts, photons per density estimate and their largest distance (m), final-gather rays.
  std::optional<int> light_samples;
  std::optional<uint64_t> photons, caustic_photons;
  std::optional<int> gather_count, final_gather;
  std::optional<double> gather_radius;
};

// `penumbra bake`: a radiosity solution as files (bake_command.cpp).
struct BakeOptions : LightmapMethodOptions, SceneInputOptions {
  std::string scene;
  std::string method = "matrix";
  std::string device = "cpu";  // progressive: cpu, gpu or auto; matrix: cpu
  std::string output = ".";    // -o DIR, created if missing
  std::string stats;
  // asset: the input's glTF with the lightmap added (io/gltf_lightmapped.h); emissive: the
  // self-contained file of io/gltf_writer.h.
  std::string gltf = "asset";
  std::string web;  // --web DIR: the viewer page beside the bake (methods/bake_output.h)
  // generate: the chart atlas of geometry/chart_atlas.h; asset: meshes with a second UV set
  // (glTF TEXCOORD_1) keep it as their lightmap layout (geometry/asset_charts.h).
  std::string lightmap_uv = "generate";
  bool preview = false;
  std::string seams = "stitch";  // stitch or off (radiosity/lightmap_seams.h)  // first a bake at a
                                 // quarter of the texel density into DIR/preview
  std::optional<uint32_t> elements;  // as RenderOptions::elements
  std::optional<int> iterations;     // as RenderOptions::iterations
  // matrix: mean squared residual of MB - E, (W m^-2)^2 (default 1e-6); progressive: unshot
  // fraction of the emitted power (default 1e-3).
  std::optional<double> tolerance;
  std::string solver = "gauss-seidel";
  // Matrix: shadow rays per cluster pair that exchanges a noticeable share (default
  // FormFactorOptions::rays).
  std::optional<int> ff_rays;
  std::optional<double> texel_density;  // lightmap texels per metre (default: from the size)
  std::optional<int> lightmap_size;     // lightmap width and height (default 1024 for matrix)
  std::string resume;                   // progressive: checkpoint to continue from
  std::string checkpoint;        // progressive: where Ctrl-C writes one (DIR/STEM.checkpoint)
  bool keep_checkpoint = false;  // progressive: keep --resume's file after the run completes
  int shooter_points = 16;       // progressive: top-level points per shooter
  std::string normals = "interpolated";  // progressive: interpolated or triangle
  std::optional<uint64_t> seed;          // stochastic, pathtrace: random seed (default 0)
  // pathtrace (radiosity/texel_path_trace.h): the most samples a texel takes; --tolerance is the
  // relative standard error each stops at. Not --spp: a scene's render settings
  // ("settings.pathtrace.spp", samples per pixel) would become the texels' cap.
  std::optional<int> texel_samples;
};

}  // namespace penumbra
