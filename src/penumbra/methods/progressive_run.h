// What `render --method progressive` and `bake --method progressive` share: choosing the
// lightmap's texel density, building the solver (or resuming a checkpoint), solving with
// progress on the terminal, and on Ctrl-C stopping between two iterations and writing a
// checkpoint (radiosity/progressive_checkpoint.h).
#pragma once

#include "penumbra/cluster/communicator.h"
#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/methods/render.h"
#include "penumbra/radiosity/progressive.h"
#include "penumbra/scene/scene.h"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

namespace penumbra {

struct ProgressiveRunOptions {
  uint32_t elements = kProgressiveDefaultElements;  // about this many lightmap texels
  std::optional<double> texel_density;              // texels per metre (overrides elements)
  std::optional<int> lightmap_size;  // an N x N atlas at the largest density that fits
  bool asset_uvs = false;            // ChartAtlasOptions::asset_uvs (--lightmap-uv asset)
  int iterations = 500;              // cap on iterations, counted over resumed runs
  double tolerance = 1e-3;           // unshot fraction
  std::string resume;                // checkpoint to continue from
  std::string checkpoint;            // where Ctrl-C writes the checkpoint
  bool keep_checkpoint = false;      // keep `resume` after a run that completes
  int shooter_points = 16;           // ProgressiveOptions::shooter_top_points
  int penumbra_rays = 16;            // ProgressiveOptions::penumbra_rays (--ff-rays)
  std::string device = "cpu";        // cpu, gpu or auto (design doc sec. 3)
  bool shading_normals = true;       // ProgressiveOptions::shading_normals (CPU only)
  // ProgressiveOptions' receivers and adaptive subdivision (sec. 4).
  bool adaptive = false;
  int receiver_level = -1;
  SubdivisionOptions subdivision;
  std::vector<std::string> given;  // LightmapMethodOptions::given
};

struct ProgressiveRun {
  std::optional<ProgressiveRadiosity> solver;  // holds the solution (also after a GPU solve)
  std::optional<Image> lightmap;               // radiance B / pi per texel, gaps filled (sec. 3.1)
  std::string device = "cpu";                  // where it was solved
  ProgressiveStats stats;
  nlohmann::json history = nlohmann::json::array();   // unshot fraction after each iteration
  nlohmann::json shooters = nlohmann::json::array();  // each iteration's shooter triangle
  nlohmann::json iteration_seconds = nlohmann::json::array();
  double build_seconds = 0.0;
  int resumed_iterations = 0;  // iterations the checkpoint had done
  bool interrupted = false;    // stopped by Ctrl-C; the checkpoint was written
  bool dry_run = false;        // --dry-run: planned and checked, nothing built
};

// What `render` and `bake` pass on, from either command's options (the checkpoint path as
// given; each command has its own default).
template <typename CommandOptions>
ProgressiveRunOptions progressiveRunOptions(const CommandOptions& o) {
  ProgressiveRunOptions ro;
  ro.elements = o.elements.value_or(kProgressiveDefaultElements);
  ro.texel_density = o.texel_density;
  if constexpr (requires { o.lightmap_size; }) ro.lightmap_size = o.lightmap_size;
  if constexpr (requires { o.lightmap_uv; }) ro.asset_uvs = o.lightmap_uv == "asset";
  ro.iterations = iterationCap(o.iterations);
  ro.tolerance = o.tolerance.value_or(1e-3);
  ro.resume = o.resume;
  ro.checkpoint = o.checkpoint;
  ro.keep_checkpoint = o.keep_checkpoint;
  ro.shooter_points = o.shooter_points;
  ro.penumbra_rays = o.ff_rays.value_or(16);
  ro.device = o.device;
  ro.shading_normals = o.normals == "interpolated";
  ro.adaptive = o.adaptive;
  ro.receiver_level = o.receiver_level.value_or(-1);
  if (o.boundary.size() == 2) {
    ro.subdivision.boundary_low = o.boundary[0];
    ro.subdivision.boundary_high = o.boundary[1];
  }
  ro.subdivision.finest_level = o.finest_level;
  if (o.min_share) ro.subdivision.min_share = *o.min_share;
  ro.given = o.given;
  return ro;
}

// Before any work, for the methods whose solution is a lightmap: the texels `resolution` (or a
// checkpoint's element count) asks for fit a lightmap's index and, at `bytes_per_element`, the
// memory; errors name the option that sized the lightmap and `method`.
Status checkLightmapPlan(const Scene& scene, const LightmapResolution& resolution,
                         std::optional<uint64_t> checkpoint_elements, const std::string& method,
                         uint64_t bytes_per_element);

// Resuming `checkpoint`: an option it fixes that the caller gave (`given` holds its name) with
// another value is an error naming both ("was written with --seed 7, not 9"). `fixed` and `asked`
// are the values as a user writes them.
Status checkResumedOption(const std::vector<std::string>& given, const std::string& checkpoint,
                          const std::string& name, const std::string& fixed,
                          const std::string& asked);

// Checks the options that do not need the scene (call before any work).
Status checkProgressiveRunOptions(const ProgressiveRunOptions& options);

// Builds and solves; on Ctrl-C writes the checkpoint and returns with `interrupted`. The scene
// must have passed validateScene. Over several ranks (the current communicator) the shots are
// shared (radiosity/progressive.h), every rank returns the whole solution, rank 0 writes the
// checkpoint, and a stop request (SIGUSR1, which mpirun passes on) stops all at one iteration;
// `gate` is opened once everything is checked, before a dry run returns.
Expected<ProgressiveRun> runProgressive(const Scene& scene, const ProgressiveRunOptions& options,
                                        const CommonOptions& common, ReadyGate* gate = nullptr);

// The stats every progressive command reports.
nlohmann::json progressiveStatsJson(const ProgressiveRun& run, double tolerance);

}  // namespace penumbra
