// The `penumbra` commands (design doc sec. 4): each parses nothing, runs the library's call
// (methods/render.h, methods/trace.h) and prints what the user is told. Each returns an exit
// code: 0 success, 2 bad input or usage, 1 failure at run time.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/methods/command_options.h"
#include "penumbra/methods/render.h"
#include "penumbra/methods/trace.h"

#include <optional>
#include <string>
#include <vector>

namespace penumbra {

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
int runBake(const BakeOptions& options, const CommonOptions& common,
            const std::vector<std::string>& given = {});
int runTrace(const TraceOptions& options, const CommonOptions& common);
int runInfo(const InfoOptions& options, const CommonOptions& common);
int runRays(const RaysOptions& options, const CommonOptions& common);

// Prints "penumbra: error: <file: place: message>" and returns the exit code for its kind.
int reportError(const Error& error);
// Prints that a --dry-run found nothing wrong and returns 0.
int reportDryRun();

// Entry point of the executable.
int runCli(int argc, char** argv);

}  // namespace penumbra
