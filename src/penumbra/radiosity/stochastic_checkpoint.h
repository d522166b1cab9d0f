// Checkpoints of stochastic radiosity (Barsi and Jakab): the solver's state between two
// iterations, so that an interrupted run (Ctrl-C) continues with `--resume` to exactly the
// estimate the uninterrupted run would have reached (the state in full double precision, the
// random numbers a function of the seed and the iteration).
//
// File layout (little-endian, docs/cli.md "Checkpoints"):
//   header (72 bytes): magic "PENUMBRA-STOCHV2" (16), uint64 scene fingerprint
//   (radiosityFingerprint), double texel density, int32 atlas width, int32 atlas height, uint64
//   seed, int32 shooters per iteration, int32 burn-in, int32 iterations, int32 first shots
//   (StochasticOptions::first_shots), uint64 elements
//   body: per element the current iterate, the sum of the odd and of the even averaged iterates
//   (9 doubles), elements in the solver's order
//   trailer: uint64 FNV-1a checksum of everything before it.
// The first shots' part of the estimate is not stored: build() computes it again, the same to
// the bit. Format 1 (before the first shots; its iterate meant another thing) is refused by name.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/radiosity/stochastic.h"
#include "penumbra/scene/scene.h"

#include <cstdint>
#include <string>

namespace penumbra {

struct StochasticCheckpointInfo {
  uint64_t fingerprint = 0;
  double texel_density = 0.0;
  int atlas_width = 0, atlas_height = 0;
  uint64_t seed = 0;
  int shooters = 1;
  int burn_in = 0;
  int iterations = 0;
  int first_shots = 0;
  uint64_t elements = 0;
};

Status writeStochasticCheckpoint(const std::string& path, const Scene& scene,
                                 const StochasticRadiosity& solver);

// Reads the header (to rebuild the solver with the checkpoint's density, seed and shooters),
// checking the file's size against it.
Expected<StochasticCheckpointInfo> readStochasticCheckpointInfo(const std::string& path);

// What resuming checks before restoring the state: the file is whole (size, checksum) and was
// written for this scene's lightmap `surface` with `shading_normals`. A dry run checks this
// without building the solver.
Status checkStochasticCheckpoint(const std::string& path, const Scene& scene,
                                 const RadiositySurface& surface, bool shading_normals);

// Restores the whole checkpoint into `solver`, built for the same scene with the header's
// options. Input errors name the file and what does not match.
Status resumeStochasticCheckpoint(const std::string& path, const Scene& scene,
                                  StochasticRadiosity& solver);

}  // namespace penumbra
