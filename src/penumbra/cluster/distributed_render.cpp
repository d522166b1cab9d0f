#include "penumbra/cluster/distributed_render.h"

#include <algorithm>
#include <cstring>

namespace penumbra {

namespace {

constexpr int kRowBlockTag = 11;

}  // namespace

int rowBlockSize(int height, int ranks) {
  return std::max(1, height / (std::max(1, ranks) * 8));
}

Image renderOverRanks(
    Communicator& comm, int width, int height, int block_rows,
    const std::function<uint64_t(int y0, int y1, std::span<glm::vec3> out)>& render_rows,
    const std::function<void(int)>& on_rows, DistributedRenderStats* stats) {
  block_rows = std::max(1, block_rows);
  const uint64_t blocks = (uint64_t(height) + uint64_t(block_rows) - 1) / uint64_t(block_rows);
  Image image;
  if (comm.root()) image = Image(width, height);
  const auto rowsOf = [&](uint64_t b) {
    const int y0 = int(b) * block_rows;
    return std::pair<int, int>(y0, std::min(height, y0 + block_rows));
  };
  uint64_t my_rays = 0;
  BlockDispatchStats dispatch;
  dispatchBlocks(
      comm, blocks, kRowBlockTag,
      [&](uint64_t b) {
        const auto [y0, y1] = rowsOf(b);
        std::vector<std::byte> out(size_t(y1 - y0) * size_t(width) * sizeof(glm::vec3));
        const std::span<glm::vec3> pixels(reinterpret_cast<glm::vec3*>(out.data()),
                                          size_t(y1 - y0) * size_t(width));
        my_rays += render_rows(y0, y1, pixels);
        return out;
      },
      [&](uint64_t b, std::span<const std::byte> result) {
        const auto [y0, y1] = rowsOf(b);
        std::memcpy(&image.pixels[size_t(y0) * size_t(width)], result.data(),
                    std::min(result.size(), size_t(y1 - y0) * size_t(width) * sizeof(glm::vec3)));
        if (on_rows) on_rows(y1 - y0);
      },
      &dispatch);
  const std::vector<uint64_t> rays = allgatherValue(comm, my_rays);
  if (stats) {
    stats->block_rows = block_rows;
    stats->rays_per_rank = rays;
    stats->rays = 0;
    for (uint64_t r : rays) stats->rays += r;
    stats->blocks_per_rank = dispatch.blocks_per_rank;
    stats->bytes_received = dispatch.bytes_received;
  }
  return image;
}

}  // namespace penumbra
