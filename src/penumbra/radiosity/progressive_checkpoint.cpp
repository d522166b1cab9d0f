#include "penumbra/radiosity/progressive_checkpoint.h"

#include "penumbra/radiosity/checkpoint_io.h"

#include "penumbra/core/file_util.h"
#include "penumbra/core/hash.h"

#include <fmt/format.h>

#include <bit>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>

namespace penumbra {

namespace {

constexpr char kMagic[16] = {'P', 'E', 'N', 'U', 'M', 'B', 'R', 'A',
                             '-', 'P', 'R', 'G', 'R', 'S', 'V', '4'};
constexpr size_t kHeaderBytes = 16 + 8 + 8 + 7 * 4 + 8 + 12 * 8 + 3 * 4 + 3 * 8 + 8;

// Body bytes: B and dB per element (48), its receiver's level (1), then a flag per shooter and
// the lights.
uint64_t bodyBytes(uint64_t elements, uint64_t flags) {
  return 49 * elements + flags;
}

using Writer = CheckpointWriter;
using Reader = CheckpointReader;

Expected<ProgressiveCheckpointInfo> parseHeader(const std::string& path, const std::string& bytes,
                                                EnergyBalance* balance) {
  if (bytes.size() >= 16 && std::memcmp(bytes.data(), kMagic, 15) == 0 && bytes[15] < kMagic[15]) {
    return inputError(path, "",
                      fmt::format("was written by an earlier version of Penumbra (checkpoint "
                                  "format {}); run again without --resume",
                                  bytes[15]));
  }
  if (bytes.size() < kHeaderBytes + 8 || std::memcmp(bytes.data(), kMagic, 16) != 0) {
    return inputError(path, "", "not a Penumbra progressive radiosity checkpoint");
  }
  Reader r{bytes, 16};
  ProgressiveCheckpointInfo info;
  EnergyBalance b;
  bool ok = r.get(info.fingerprint) && r.get(info.texel_density) && r.get(info.atlas_width) &&
            r.get(info.atlas_height) && r.get(info.shooter_level) &&
            r.get(info.shooter_top_points) && r.get(info.shooter_min_points) &&
            r.get(info.iterations) && r.get(info.lights_shot) && r.get(info.elements);
  for (glm::dvec3* v : {&b.emitted, &b.absorbed, &b.unshot, &b.escaped}) {
    for (int c = 0; c < 3; ++c) ok = ok && r.get((*v)[c]);
  }
  ok = ok && r.get(info.receiver_level) && r.get(info.adaptive) &&
       r.get(info.subdivision.finest_level) && r.get(info.subdivision.boundary_low) &&
       r.get(info.subdivision.boundary_high) && r.get(info.subdivision.min_share) &&
       r.get(info.flags);
  if (!ok) return inputError(path, "header", "truncated");
  // What a checkpoint of this version can hold (the atlas at most 16384 texels a side, the
  // shooter options' ranges): a forged or corrupt header is refused here, naming the file,
  // rather than driving the build.
  if (!(info.texel_density > 0.0 && info.texel_density < 1e9) || info.atlas_width <= 0 ||
      info.atlas_height <= 0 || info.atlas_width > 16384 || info.atlas_height > 16384 ||
      info.shooter_level < 0 || info.shooter_level > 16 || info.shooter_top_points < 0 ||
      info.shooter_top_points > 4096 || info.shooter_min_points < 0 ||
      info.shooter_min_points > 4096 || info.iterations < 0 || info.lights_shot < 0 ||
      info.lights_shot > 1 || info.elements == 0 ||
      info.elements > uint64_t(info.atlas_width) * uint64_t(info.atlas_height) ||
      info.receiver_level < 0 || info.receiver_level > 16 || info.adaptive < 0 ||
      info.adaptive > 1 || !checkSubdivisionOptions(info.subdivision).ok() ||
      info.flags > info.elements + 1) {
    return inputError(path, "header", "values out of range");
  }
  if (balance) *balance = b;
  return info;
}

}  // namespace

uint64_t progressiveFingerprint(const Scene& scene, const ProgressiveRadiosity& solver) {
  return radiosityFingerprint(scene, solver.surface(), solver.options().shading_normals);
}

Status writeProgressiveCheckpoint(const std::string& path, const Scene& scene,
                                  const ProgressiveRadiosity& solver) {
  const ProgressiveState state = solver.state();
  Writer w;
  w.bytes.reserve(kHeaderBytes + 49 * solver.elementCount() + 8 + solver.shooterCount() + 1);
  w.bytes.append(kMagic, 16);
  w.put(progressiveFingerprint(scene, solver));
  w.put(solver.atlas().texel_density);
  w.put(int32_t(solver.atlas().width));
  w.put(int32_t(solver.atlas().height));
  w.put(int32_t(solver.options().shooter_level));
  w.put(int32_t(solver.options().shooter_top_points));
  w.put(int32_t(solver.options().shooter_min_points));
  w.put(int32_t(state.iterations));
  w.put(int32_t(state.lights_shot ? 1 : 0));
  w.put(uint64_t(solver.elementCount()));
  for (const glm::dvec3* v : {&state.balance.emitted, &state.balance.absorbed,
                              &state.balance.unshot, &state.balance.escaped}) {
    for (int c = 0; c < 3; ++c) w.put((*v)[c]);
  }
  const ProgressiveOptions& o = solver.options();
  w.put(int32_t(solver.receiverLevel()));
  w.put(int32_t(o.adaptive ? 1 : 0));
  w.put(int32_t(o.subdivision.finest_level));
  w.put(o.subdivision.boundary_low);
  w.put(o.subdivision.boundary_high);
  w.put(o.subdivision.min_share);
  w.put(uint64_t(state.subdivided.size()));
  for (size_t e = 0; e < solver.elementCount(); ++e) {
    for (int c = 0; c < 3; ++c) w.put(state.radiosity[e][c]);
    for (int c = 0; c < 3; ++c) w.put(state.residual[e][c]);
  }
  w.bytes.append(reinterpret_cast<const char*>(state.receiver_levels.data()),
                 state.receiver_levels.size());
  w.bytes.append(reinterpret_cast<const char*>(state.subdivided.data()), state.subdivided.size());
  return writeCheckpointFile(path, w);
}

Expected<ProgressiveCheckpointInfo> readProgressiveCheckpointInfo(const std::string& path) {
  // The header is all that is needed; the file is read whole for simplicity only when resuming.
  PENUMBRA_TRY(checkInputFile(path));
  std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!f) return inputError(path, "", "cannot open the checkpoint");
  std::string bytes(kHeaderBytes + 8, '\0');
  bytes.resize(std::fread(bytes.data(), 1, bytes.size(), f.get()));
  Expected<ProgressiveCheckpointInfo> info = parseHeader(path, bytes, nullptr);
  if (!info) return info;
  // The body holds 49 bytes per element, the flags and a checksum: the element count is checked
  // against the file's size before anything is built for it.
  std::error_code ec;
  const uint64_t size = std::filesystem::file_size(path, ec);
  if (ec || info->elements > (size - std::min<uint64_t>(size, kHeaderBytes)) / 49 ||
      size != kHeaderBytes + bodyBytes(info->elements, info->flags) + 8) {
    return inputError(path, "",
                      fmt::format("truncated or padded: {} bytes for {} elements", ec ? 0 : size,
                                  info->elements));
  }
  return info;
}

Status resumeProgressiveCheckpoint(const std::string& path, const Scene& scene,
                                   ProgressiveRadiosity& solver) {
  Expected<std::string> bytes = readFile(path);
  if (!bytes) return bytes.error();
  EnergyBalance balance;
  Expected<ProgressiveCheckpointInfo> info = parseHeader(path, *bytes, &balance);
  if (!info) return info.error();
  const uint64_t n = info->elements;
  if (n > (bytes->size() - kHeaderBytes) / 49 ||
      bytes->size() != kHeaderBytes + bodyBytes(n, info->flags) + 8) {
    return inputError(
        path, "", fmt::format("truncated or padded: {} bytes for {} elements", bytes->size(), n));
  }
  if (!checkpointChecksumMatches(*bytes)) {
    return inputError(path, "", "corrupt (checksum mismatch)");
  }
  if (info->fingerprint != progressiveFingerprint(scene, solver) || n != solver.elementCount()) {
    return inputError(path, "",
                      fmt::format("was written for another scene, lightmap or --normals setting "
                                  "({} elements in a {}x{} atlas; this run has {} in {}x{})",
                                  n, info->atlas_width, info->atlas_height, solver.elementCount(),
                                  solver.atlas().width, solver.atlas().height));
  }
  if (info->shooter_level != solver.options().shooter_level ||
      info->shooter_top_points != solver.options().shooter_top_points ||
      info->shooter_min_points != solver.options().shooter_min_points) {
    return inputError(path, "", "was written with other substructuring options");
  }
  const SubdivisionOptions& sub = solver.options().subdivision;
  if (info->receiver_level != solver.receiverLevel() ||
      (info->adaptive != 0) != solver.options().adaptive ||
      info->subdivision.finest_level != sub.finest_level ||
      info->subdivision.boundary_low != sub.boundary_low ||
      info->subdivision.boundary_high != sub.boundary_high ||
      info->subdivision.min_share != sub.min_share) {
    return inputError(path, "", "was written with other receiver or subdivision options");
  }
  ProgressiveState state;
  state.balance = balance;
  state.iterations = info->iterations;
  state.lights_shot = info->lights_shot != 0;
  state.radiosity.resize(n);
  state.residual.resize(n);
  Reader r{*bytes, kHeaderBytes};
  for (uint64_t e = 0; e < n; ++e) {
    for (int c = 0; c < 3; ++c) (void)r.get(state.radiosity[e][c]);
    for (int c = 0; c < 3; ++c) (void)r.get(state.residual[e][c]);
  }
  state.receiver_levels.assign(bytes->begin() + std::ptrdiff_t(r.at),
                               bytes->begin() + std::ptrdiff_t(r.at + n));
  r.at += n;
  state.subdivided.assign(bytes->begin() + std::ptrdiff_t(r.at),
                          bytes->begin() + std::ptrdiff_t(r.at + info->flags));
  Status s = solver.setState(std::move(state));
  if (!s.ok()) return inputError(path, "", s.error().message);
  return {};
}

}  // namespace penumbra
