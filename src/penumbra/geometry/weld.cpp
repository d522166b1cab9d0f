#include "penumbra/geometry/weld.h"

#include <cstring>
#include <unordered_map>

namespace penumbra {

std::vector<uint32_t> weldPositions(std::span<const glm::vec3> positions) {
  struct Hash {
    size_t operator()(const glm::vec3& p) const {
      uint32_t b[3];
      std::memcpy(b, &p, sizeof(b));
      return (size_t(b[0]) * 73856093u) ^ (size_t(b[1]) * 19349663u) ^ (size_t(b[2]) * 83492791u);
    }
  };
  std::unordered_map<glm::vec3, uint32_t, Hash> ids;
  ids.reserve(positions.size());
  std::vector<uint32_t> weld(positions.size());
  for (size_t i = 0; i < positions.size(); ++i) {
    weld[i] = ids.emplace(positions[i], uint32_t(ids.size())).first->second;
  }
  return weld;
}

}  // namespace penumbra
