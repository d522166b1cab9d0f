// Checkpoints of progressive radiosity (Wallner sec. 2-3): the solver's state between two
// iterations, so that an interrupted run (Ctrl-C) can be continued with `--resume` and reach
// exactly the solution the uninterrupted run would have reached (the state is stored in full
// double precision and the shooter order is deterministic).
//
// File layout (little-endian, docs/cli.md "Checkpoints"):
//   header (208 bytes): magic "PENUMBRA-PRGRSV4" (16), uint64 scene fingerprint, double texel
//   density, int32 atlas width, int32 atlas height, int32 shooter level, int32 shooter top
//   points, int32 shooter minimum points, int32 iterations, uint64 elements, then the energy books
//   (emitted, absorbed, unshot, escaped: 4 x 3 doubles), the receivers' options (int32 receiver
//   level, int32 adaptive, int32 finest level, double b_l, double b_u, double minimum share) and
//   uint64 the number of subdivision flags body: per element B (3 doubles) then dB (3 doubles),
//   elements in the solver's order; per element the level of its receiver (uint8); the subdivision
//   flags (uint8 per shooter, then the lights) trailer: uint64 FNV-1a hash of everything before it.
// The fingerprint hashes the flattened scene (positions, triangles, materials' reflectance and
// emission) with the atlas's size and the normals setting, so a checkpoint is refused for
// another scene, lightmap or setting.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/radiosity/progressive.h"
#include "penumbra/scene/scene.h"

#include <cstdint>
#include <string>

namespace penumbra {

// What a checkpoint says about the solver it came from: enough to rebuild the same atlas.
struct ProgressiveCheckpointInfo {
  uint64_t fingerprint = 0;
  double texel_density = 0.0;
  int atlas_width = 0, atlas_height = 0;
  int shooter_level = 0;
  int shooter_top_points = 0;
  int shooter_min_points = 0;
  int iterations = 0;
  int lights_shot = 1;  // 0 or 1
  uint64_t elements = 0;
  int receiver_level = 0;
  int adaptive = 0;  // 0 or 1
  SubdivisionOptions subdivision;
  uint64_t flags = 0;
};

// The fingerprint of a scene's geometry and materials and of the solver's atlas.
uint64_t progressiveFingerprint(const Scene& scene, const ProgressiveRadiosity& solver);

// Writes the solver's state (atomically: a temporary file renamed into place).
Status writeProgressiveCheckpoint(const std::string& path, const Scene& scene,
                                  const ProgressiveRadiosity& solver);

// Reads the header only (to rebuild the solver with the checkpoint's texel density).
Expected<ProgressiveCheckpointInfo> readProgressiveCheckpointInfo(const std::string& path);

// Reads the whole checkpoint and restores it into `solver`, which must have been built for the
// same scene with the density the header gives. Input errors name the file and what does not
// match.
Status resumeProgressiveCheckpoint(const std::string& path, const Scene& scene,
                                   ProgressiveRadiosity& solver);

}  // namespace penumbra
