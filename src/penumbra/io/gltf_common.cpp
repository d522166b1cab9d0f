#include "penumbra/io/gltf_common.h"

#include <fmt/format.h>

namespace penumbra {

namespace {

uint32_t readLe32(std::string_view bytes, size_t at) {
  const auto* b = reinterpret_cast<const unsigned char*>(bytes.data() + at);
  return uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24;
}

}  // namespace

Expected<std::string_view> glbJsonChunk(const std::string& path, std::string_view bytes) {
  if (bytes.size() < 20) return inputError(path, "GLB header", "the file is cut short");
  const uint32_t version = readLe32(bytes, 4);
  if (version != 2) {
    return inputError(path, "GLB header",
                      fmt::format("GLB version {} is not supported (glTF 2.0 files are GLB "
                                  "version 2)",
                                  version));
  }
  const uint32_t length = readLe32(bytes, 8);
  if (length != bytes.size()) {
    return inputError(path, "GLB header",
                      fmt::format("the header gives a length of {} bytes, the file has {}", length,
                                  bytes.size()));
  }
  const uint32_t chunk = readLe32(bytes, 12);
  if (readLe32(bytes, 16) != 0x4E4F534Au) {
    return inputError(path, "GLB header", "the first chunk is not JSON");
  }
  if (chunk > bytes.size() - 20) {
    return inputError(path, "GLB JSON chunk",
                      fmt::format("its length {} runs past the end of the file", chunk));
  }
  return bytes.substr(20, chunk);
}

bool keepGltfImageBytes(tinygltf::Image*, const int image_index, std::string*, std::string*, int,
                        int, const unsigned char* bytes, int size, void* user) {
  auto* kept = static_cast<std::map<int, std::string>*>(user);
  if (bytes && size > 0) {
    (*kept)[image_index] = std::string(reinterpret_cast<const char*>(bytes), size_t(size));
  }
  return true;
}

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
