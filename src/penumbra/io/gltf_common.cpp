#include "penumbra/io/gltf_common.h"

#include <fmt/format.h>

namespace penumbra {

std::vector<uint32_t> gltfTriangleCorners(int mode, const std::vector<uint32_t>& seq) {
  std::vector<uint32_t> corners;
  const size_t n = seq.size();
  if (mode == 4) {
    corners.assign(seq.begin(), seq.begin() + std::ptrdiff_t(n - n % 3));
    return corners;
  }
  corners.reserve(n > 2 ? 3 * (n - 2) : 0);
  for (size_t i = 0; i + 2 < n; ++i) {
    if (mode == 6) {
      corners.insert(corners.end(), {seq[0], seq[i + 1], seq[i + 2]});
    } else if (i % 2 == 0) {
      corners.insert(corners.end(), {seq[i], seq[i + 1], seq[i + 2]});
    } else {
      corners.insert(corners.end(), {seq[i], seq[i + 2], seq[i + 1]});
    }
  }
  return corners;
}

}  // namespace penumbra
