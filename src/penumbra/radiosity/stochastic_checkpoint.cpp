#include "penumbra/radiosity/stochastic_checkpoint.h"

#include "penumbra/core/file_util.h"
#include "penumbra/radiosity/checkpoint_io.h"

#include <fmt/format.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>

namespace penumbra {

namespace {

constexpr char kMagic[16] = {'P', 'E', 'N', 'U', 'M', 'B', 'R', 'A',
                             '-', 'S', 'T', 'O', 'C', 'H', 'V', '2'};
constexpr size_t kHeaderBytes = 16 + 8 + 8 + 2 * 4 + 8 + 4 * 4 + 8;
constexpr size_t kElementBytes = 9 * 8;

Expected<StochasticCheckpointInfo> parseHeader(const std::string& path, const std::string& bytes) {
  if (bytes.size() >= 16 && std::memcmp(bytes.data(), kMagic, 15) == 0 && bytes[15] >= '1' &&
      bytes[15] < kMagic[15]) {
    return inputError(path, "",
                      fmt::format("was written by an earlier version of Penumbra (checkpoint "
                                  "format {}); run again without --resume",
                                  bytes[15]));
  }
  if (bytes.size() < kHeaderBytes + 8 || std::memcmp(bytes.data(), kMagic, 16) != 0) {
    return inputError(path, "", "not a Penumbra stochastic radiosity checkpoint");
  }
  CheckpointReader r{bytes, 16};
  StochasticCheckpointInfo info;
  const bool ok = r.get(info.fingerprint) && r.get(info.texel_density) && r.get(info.atlas_width) &&
                  r.get(info.atlas_height) && r.get(info.seed) && r.get(info.shooters) &&
                  r.get(info.burn_in) && r.get(info.iterations) && r.get(info.first_shots) &&
                  r.get(info.elements);
  if (!ok) return inputError(path, "header", "truncated");
  if (!(info.texel_density > 0.0 && info.texel_density < 1e9) || info.atlas_width <= 0 ||
      info.atlas_height <= 0 || info.atlas_width > 16384 || info.atlas_height > 16384 ||
      info.shooters < 1 || info.shooters > 4096 || info.burn_in < 0 || info.burn_in > 1000000 ||
      info.iterations < 0 || info.first_shots < 0 || info.first_shots > 4096 ||
      info.elements == 0 ||
      info.elements > uint64_t(info.atlas_width) * uint64_t(info.atlas_height)) {
    return inputError(path, "header", "values out of range");
  }
  return info;
}

}  // namespace

Status writeStochasticCheckpoint(const std::string& path, const Scene& scene,
                                 const StochasticRadiosity& solver) {
  const StochasticState state = solver.state();
  CheckpointWriter w;
  w.bytes.reserve(kHeaderBytes + kElementBytes * solver.elementCount() + 8);
  w.bytes.append(kMagic, 16);
  w.put(radiosityFingerprint(scene, solver.surface(), solver.options().shading_normals));
  w.put(solver.atlas().texel_density);
  w.put(int32_t(solver.atlas().width));
  w.put(int32_t(solver.atlas().height));
  w.put(uint64_t(solver.options().seed));
  w.put(int32_t(solver.options().shooters));
  w.put(int32_t(solver.burnIn()));
  w.put(int32_t(state.iterations));
  w.put(int32_t(solver.options().first_shots));
  w.put(uint64_t(solver.elementCount()));
  for (size_t e = 0; e < solver.elementCount(); ++e) {
    for (const glm::dvec3* v : {&state.iterate[e], &state.sum_odd[e], &state.sum_even[e]}) {
      for (int c = 0; c < 3; ++c) w.put((*v)[c]);
    }
  }
  return writeCheckpointFile(path, w);
}

Expected<StochasticCheckpointInfo> readStochasticCheckpointInfo(const std::string& path) {
  PENUMBRA_TRY(checkInputFile(path));
  std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!f) return inputError(path, "", "cannot open the checkpoint");
  std::string bytes(kHeaderBytes + 8, '\0');
  bytes.resize(std::fread(bytes.data(), 1, bytes.size(), f.get()));
  Expected<StochasticCheckpointInfo> info = parseHeader(path, bytes);
  if (!info) return info;
  std::error_code ec;
  const uint64_t size = std::filesystem::file_size(path, ec);
  if (ec || info->elements > (size - std::min<uint64_t>(size, kHeaderBytes)) / kElementBytes ||
      size != kHeaderBytes + kElementBytes * info->elements + 8) {
    return inputError(path, "",
                      fmt::format("truncated or padded: {} bytes for {} elements", ec ? 0 : size,
                                  info->elements));
  }
  return info;
}

namespace {

// The checks of checkStochasticCheckpoint on the file's bytes; the header's fields in `info`.
Status checkBytes(const std::string& path, const std::string& bytes, const Scene& scene,
                  const RadiositySurface& surface, bool shading_normals,
                  StochasticCheckpointInfo& info) {
  Expected<StochasticCheckpointInfo> header = parseHeader(path, bytes);
  if (!header) return header.error();
  info = *header;
  const uint64_t n = info.elements;
  if (n > (bytes.size() - kHeaderBytes) / kElementBytes ||
      bytes.size() != kHeaderBytes + kElementBytes * n + 8) {
    return inputError(
        path, "", fmt::format("truncated or padded: {} bytes for {} elements", bytes.size(), n));
  }
  if (!checkpointChecksumMatches(bytes)) {
    return inputError(path, "", "corrupt (checksum mismatch)");
  }
  if (info.fingerprint != radiosityFingerprint(scene, surface, shading_normals) ||
      n != surface.elementCount()) {
    return inputError(path, "",
                      fmt::format("was written for another scene, lightmap or --normals setting "
                                  "({} elements in a {}x{} atlas; this run has {} in {}x{})",
                                  n, info.atlas_width, info.atlas_height, surface.elementCount(),
                                  surface.atlas.width, surface.atlas.height));
  }
  return {};
}

}  // namespace

Status checkStochasticCheckpoint(const std::string& path, const Scene& scene,
                                 const RadiositySurface& surface, bool shading_normals) {
  Expected<std::string> bytes = readFile(path);
  if (!bytes) return bytes.error();
  StochasticCheckpointInfo info;
  return checkBytes(path, *bytes, scene, surface, shading_normals, info);
}

Status resumeStochasticCheckpoint(const std::string& path, const Scene& scene,
                                  StochasticRadiosity& solver) {
  Expected<std::string> bytes = readFile(path);
  if (!bytes) return bytes.error();
  StochasticCheckpointInfo header;
  PENUMBRA_TRY(
      checkBytes(path, *bytes, scene, solver.surface(), solver.options().shading_normals, header));
  const uint64_t n = header.elements;
  if (header.seed != solver.options().seed || header.shooters != solver.options().shooters ||
      header.burn_in != solver.burnIn() || header.first_shots != solver.options().first_shots) {
    return inputError(path, "",
                      "was written with another seed, --shooters, --first-shots or burn-in");
  }
  StochasticState state;
  state.iterations = header.iterations;
  state.iterate.resize(n);
  state.sum_odd.resize(n);
  state.sum_even.resize(n);
  CheckpointReader r{*bytes, kHeaderBytes};
  for (uint64_t e = 0; e < n; ++e) {
    for (glm::dvec3* v : {&state.iterate[e], &state.sum_odd[e], &state.sum_even[e]}) {
      for (int c = 0; c < 3; ++c) (void)r.get((*v)[c]);
    }
  }
  Status s = solver.setState(std::move(state));
  if (!s.ok()) return inputError(path, "", s.error().message);
  return {};
}

}  // namespace penumbra
