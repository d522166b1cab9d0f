// What `render --method stochastic` and `bake --method stochastic` share: the lightmap's texel
// density, building the solver (or resuming a checkpoint), iterating with progress on the
// terminal (the iteration and the running error estimate), and on Ctrl-C stopping between two
// iterations with the estimate so far and a checkpoint (radiosity/stochastic_checkpoint.h).
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/methods/render.h"
#include "penumbra/radiosity/radiosity_surface.h"
#include "penumbra/radiosity/stochastic.h"
#include "penumbra/scene/scene.h"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

namespace penumbra {

struct StochasticRunOptions {
  uint32_t elements = kDefaultLightmapElements;  // about this many lightmap texels
  std::optional<double> texel_density;           // texels per metre (overrides elements)
  std::optional<int> lightmap_size;              // an N x N atlas at the largest density that fits
  bool asset_uvs = false;                        // ChartAtlasOptions::asset_uvs
  int iterations = kStochasticIterationCap;      // cap, counted over resumed runs
  double time_limit = 0.0;                       // seconds; 0: none
  int shooters = 1;
  int first_shots = kStochasticFirstShots;
  uint64_t seed = 0;
  std::string resume;
  std::string checkpoint;
  bool keep_checkpoint = false;
  std::string device = "cpu";
  bool shading_normals = true;
  std::vector<std::string> given;  // LightmapMethodOptions::given
};

static_assert(LightmapMethodOptions{}.first_shots == kStochasticFirstShots);
static_assert(StochasticOptions{}.iterations == kStochasticIterationCap);

struct StochasticRun {
  std::optional<StochasticRadiosity> solver;
  std::optional<Image> lightmap;  // radiance B~ / pi per texel, gaps filled
  std::string device = "cpu";
  StochasticStats stats;
  nlohmann::json history = nlohmann::json::array();  // error estimate after each iteration
  double build_seconds = 0.0;
  int resumed_iterations = 0;
  bool interrupted = false;
  bool dry_run = false;
};

template <typename CommandOptions>
StochasticRunOptions stochasticRunOptions(const CommandOptions& o) {
  StochasticRunOptions ro;
  ro.elements = o.elements.value_or(kDefaultLightmapElements);
  ro.texel_density = o.texel_density;
  if constexpr (requires { o.lightmap_size; }) ro.lightmap_size = o.lightmap_size;
  if constexpr (requires { o.lightmap_uv; }) ro.asset_uvs = o.lightmap_uv == "asset";
  ro.iterations = iterationCap(o.iterations, o.time_limit, kStochasticIterationCap);
  ro.time_limit = o.time_limit.value_or(0.0);
  ro.shooters = o.shooters;
  ro.first_shots = o.first_shots;
  ro.seed = o.seed.value_or(0);
  ro.resume = o.resume;
  ro.checkpoint = o.checkpoint;
  ro.keep_checkpoint = o.keep_checkpoint;
  ro.device = o.device;
  ro.shading_normals = o.normals == "interpolated";
  ro.given = o.given;
  return ro;
}

// Checks the options that do not need the scene (call before any work).
Status checkStochasticRunOptions(const StochasticRunOptions& options);

// Builds and iterates; on Ctrl-C writes the checkpoint and returns with `interrupted`. The scene
// must have passed validateScene.
Expected<StochasticRun> runStochastic(const Scene& scene, const StochasticRunOptions& options,
                                      const CommonOptions& common);

nlohmann::json stochasticStatsJson(const StochasticRun& run);

}  // namespace penumbra
