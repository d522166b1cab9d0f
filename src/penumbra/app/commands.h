// The `penumbra` commands (design doc sec. 4). Each returns an exit code: 0 success, 2 bad input
// or usage, 1 failure at run time.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/methods/command_options.h"

#include <optional>
#include <string>
#include <vector>

namespace penumbra {

struct TraceOptions {
  std::string mesh;
  // --device hybrid: GPU cells hold t_min..t_max triangles; r_min rays per GPU pass (sec. 6.2);
  // each cell's ray cache holds cache_rays rays (sec. 5.3; unset: 4 r_min).
  uint32_t t_min = 64, t_max = 1024, r_min = 256;
  std::optional<uint32_t> cache_rays;
  std::string rays;
  std::string output;
  std::string stats;
  std::string device = "auto";
  bool occlusion = false;  // any hit: one byte per ray instead of closest hits
};

// `penumbra rays`: a ray file from a scene (rays_command.cpp).
struct RaysOptions {
  std::string scene;
  std::string kind = "camera";       // camera: one ray per pixel; diffuse: from the surface
  std::optional<int> width, height;  // camera: image size (default 512 x 512)
  std::optional<uint64_t> count;     // diffuse: number of rays (default 2^20)
  uint64_t seed = 0;                 // diffuse
  std::optional<float> t_min;        // diffuse: tmin (default 1e-4 of the scene's diagonal)
  std::string output;
};

struct InfoOptions {
  std::string scene = "cornell";
  bool devices = false;  // list the OpenGL contexts that can be made instead
  std::string plot;      // a photometric file's polar plot (PNG)
};

// `given`: the options the command line set (the scene file's settings apply to the others).
int runRender(RenderOptions options, const CommonOptions& common,
              const std::vector<std::string>& given = {});
int runBake(const BakeOptions& options, const CommonOptions& common);
// The methods behind `render` (render_*.cpp).
Status renderMatrix(const RenderOptions& options, const CommonOptions& common);
// --method progressive and stochastic. Sets *interrupted when Ctrl-C stopped the solver (the
// outputs and a checkpoint were written).
Status renderLightmapRadiosity(const RenderOptions& options, const CommonOptions& common,
                               bool* interrupted);
Status renderSss(const RenderOptions& options, const CommonOptions& common);
Status renderLpv(const RenderOptions& options, const CommonOptions& common);
// --method whitted and photons (render_whitted.cpp).
Status renderRayTraced(const RenderOptions& options, const CommonOptions& common);
// out.png -> out_0007.png: frame f of a sequence.
std::string sequenceFrameName(const std::string& path, int frame);
// The render's image outputs (SCENE.png when none is given), each checked before the work: a
// known format and a writable place; for a sequence of `frames` > 1 its directory is made (and
// removed again if the run fails) and frame 0's name checked. The stats file is checked too.
Expected<std::vector<std::string>> checkRenderOutputs(const RenderOptions& options, int frames);
int runTrace(const TraceOptions& options, const CommonOptions& common);
int runInfo(const InfoOptions& options, const CommonOptions& common);
int runRays(const RaysOptions& options, const CommonOptions& common);

// Prints "penumbra: error: <file: place: message>" and returns the exit code for its kind.
int reportError(const Error& error);
// Prints that a --dry-run found nothing wrong and returns 0.
int reportDryRun();

// Entry point of the executable.
int runCli(int argc, char** argv);
// The same for a program calling the library (app/session.h): `args` as argv (the program's name
// first); exceptions (Interrupted, InternalError, std::bad_alloc) reach the caller.
int runCommandLine(const std::vector<std::string>& args);

}  // namespace penumbra
