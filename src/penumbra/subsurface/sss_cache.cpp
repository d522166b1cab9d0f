#include "penumbra/subsurface/sss_cache.h"

#include "penumbra/core/file_util.h"
#include "penumbra/core/hash.h"

#include <fmt/format.h>

#include <bit>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace penumbra {

namespace {

static_assert(std::endian::native == std::endian::little, "the cache is little-endian");

constexpr char kMagic[16] = {'P', 'E', 'N', 'U', 'M', 'B', 'R', 'A',
                             '-', 'S', 'S', 'S', 'L', 'N', 'K', '2'};
constexpr size_t kHeaderBytes = 16 + 8 + 8 + 4 + 8;

std::string cacheFile(const std::string& directory, uint64_t fingerprint) {
  return (std::filesystem::path(directory) / fmt::format("sss-links-{:016x}.bin", fingerprint))
      .string();
}

template <typename T>
void hashVector(Fnv1a& h, const std::vector<T>& v) {
  h.addValue(uint64_t(v.size()));
  h.add(v.data(), v.size() * sizeof(T));
}

}  // namespace

std::string defaultCacheDirectory() {
  if (const char* d = std::getenv("PENUMBRA_CACHE_DIR"); d && *d) return d;
  if (const char* d = std::getenv("XDG_CACHE_HOME"); d && *d) {
    return (std::filesystem::path(d) / "penumbra").string();
  }
  if (const char* d = std::getenv("HOME"); d && *d) {
    return (std::filesystem::path(d) / ".cache" / "penumbra").string();
  }
  return "";
}

uint64_t sssLinksFingerprint(const SssTree& tree, std::span<const Dipole> media,
                             const SssLinkOptions& options) {
  Fnv1a h;
  h.add(kMagic, sizeof(kMagic));
  hashVector(h, tree.position);
  hashVector(h, tree.area);
  hashVector(h, tree.radius);
  hashVector(h, tree.object);
  hashVector(h, tree.child_first);
  hashVector(h, tree.child_index);
  hashVector(h, tree.level_offset);
  hashVector(h, tree.object_root);
  hashVector(h, tree.axis_x);
  hashVector(h, tree.axis_y);
  for (const Dipole& d : media) {
    for (const DipoleChannel& c : d.channel) {
      h.addValue(c.alpha);
      h.addValue(c.sigma_tr);
      h.addValue(c.z_r);
      h.addValue(c.z_v);
    }
  }
  h.addValue(options.links);
  h.addValue(options.level);
  h.addValue(kNearFactor);
  h.addValue(kTouchFactor);
  return h.h;
}

std::optional<SssLinks> readCachedSssLinks(const std::string& directory, uint64_t fingerprint,
                                           const SssTree& tree) {
  if (directory.empty()) return std::nullopt;
  const std::string path = cacheFile(directory, fingerprint);
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return std::nullopt;
  std::ifstream in(path, std::ios::binary);
  char header[kHeaderBytes];
  if (!in.read(header, kHeaderBytes) || std::memcmp(header, kMagic, 16) != 0) return std::nullopt;
  uint64_t fp = 0, elements = 0, nodes = 0;
  uint32_t per = 0;
  std::memcpy(&fp, header + 16, 8);
  std::memcpy(&elements, header + 24, 8);
  std::memcpy(&per, header + 32, 4);
  std::memcpy(&nodes, header + 36, 8);
  if (fp != fingerprint || elements != tree.elementCount() || nodes != tree.nodeCount() ||
      per == 0 || per > 65536) {
    return std::nullopt;
  }
  const uint64_t count = elements * per;
  const uint64_t expected = kHeaderBytes + count * (4 + 12 + 12);
  if (std::filesystem::file_size(path, ec) != expected || ec) return std::nullopt;
  SssLinks links;
  links.per_element = per;
  links.node.resize(count);
  links.factor.resize(count);
  links.offset.resize(count);
  if (!in.read(reinterpret_cast<char*>(links.node.data()), std::streamsize(count * 4)) ||
      !in.read(reinterpret_cast<char*>(links.factor.data()), std::streamsize(count * 12)) ||
      !in.read(reinterpret_cast<char*>(links.offset.data()), std::streamsize(count * 12))) {
    return std::nullopt;
  }
  for (uint64_t k = 0; k < count; ++k) {
    const glm::vec3& f = links.factor[k];
    const glm::vec3& o = links.offset[k];
    if (links.node[k] >= nodes || !(f.x >= 0.0f && f.y >= 0.0f && f.z >= 0.0f) ||
        !std::isfinite(f.x + f.y + f.z) || !std::isfinite(o.x + o.y + o.z)) {
      return std::nullopt;
    }
  }
  return links;
}

Status writeCachedSssLinks(const std::string& directory, uint64_t fingerprint, const SssTree& tree,
                           const SssLinks& links) {
  if (directory.empty()) return inputError("", "", "no cache directory (set PENUMBRA_CACHE_DIR)");
  std::error_code ec;
  std::filesystem::create_directories(directory, ec);
  if (ec) return runtimeError(directory, fmt::format("cannot create it: {}", ec.message()));
  return writeAtomicallyNow(
      cacheFile(directory, fingerprint), [&](const std::string& tmp) -> Status {
        std::ofstream out(tmp, std::ios::binary);
        char header[kHeaderBytes];
        std::memcpy(header, kMagic, 16);
        const uint64_t elements = tree.elementCount(), nodes = tree.nodeCount();
        std::memcpy(header + 16, &fingerprint, 8);
        std::memcpy(header + 24, &elements, 8);
        std::memcpy(header + 32, &links.per_element, 4);
        std::memcpy(header + 36, &nodes, 8);
        out.write(header, kHeaderBytes);
        out.write(reinterpret_cast<const char*>(links.node.data()),
                  std::streamsize(links.node.size() * 4));
        out.write(reinterpret_cast<const char*>(links.factor.data()),
                  std::streamsize(links.factor.size() * 12));
        out.write(reinterpret_cast<const char*>(links.offset.data()),
                  std::streamsize(links.offset.size() * 12));
        out.close();
        if (!out) return runtimeError(tmp, "cannot write the link cache");
        return {};
      });
}

}  // namespace penumbra
