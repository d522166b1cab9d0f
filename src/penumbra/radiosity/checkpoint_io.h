// What the radiosity methods' checkpoints share (radiosity/progressive_checkpoint.h,
// stochastic_checkpoint.h): little-endian raw values appended to a byte string and read back
// with bounds checks, a trailing FNV-1a checksum, atomic writing, and the fingerprint that ties a
// checkpoint to its scene and lightmap.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/radiosity/radiosity_surface.h"
#include "penumbra/scene/scene.h"

#include <bit>
#include <cstdint>
#include <cstring>
#include <string>

namespace penumbra {

static_assert(std::endian::native == std::endian::little, "checkpoints are little-endian");

struct CheckpointWriter {
  std::string bytes;
  template <typename T>
  void put(const T& v) {
    bytes.append(reinterpret_cast<const char*>(&v), sizeof(v));
  }
};

struct CheckpointReader {
  const std::string& bytes;
  size_t at = 0;
  template <typename T>
  bool get(T& v) {
    if (bytes.size() - at < sizeof(v)) return false;
    std::memcpy(&v, bytes.data() + at, sizeof(v));
    at += sizeof(v);
    return true;
  }
};

// Appends the FNV-1a checksum of the bytes so far and writes them to `path` atomically (a
// temporary renamed into place), at once even inside an output transaction.
Status writeCheckpointFile(const std::string& path, CheckpointWriter& writer);
// Whether the last 8 bytes are the checksum of the rest.
bool checkpointChecksumMatches(const std::string& bytes);

// The flattened scene (positions, triangles, materials' reflectance, emission and sidedness,
// the lights) with the lightmap's size, element count and the normals setting.
uint64_t radiosityFingerprint(const Scene& scene, const RadiositySurface& surface,
                              bool shading_normals);

}  // namespace penumbra
