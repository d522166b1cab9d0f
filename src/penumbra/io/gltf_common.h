// What the glTF reader (io/gltf_loader.cpp) and the lightmapped writer (io/gltf_lightmapped.h)
// share, so that both read a file the same way: the GLB container, the images' bytes as
// tinygltf hands them over, and a primitive's triangles in the file's order.
#pragma once

#include "penumbra/core/expected.h"

#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace tinygltf {
struct Image;
}

namespace penumbra {

// The JSON chunk of a GLB file, after checking the header (glTF 2.0, sec. 4.4: magic, version
// 2, length, then a JSON chunk first); an input error naming `path` otherwise.
Expected<std::string_view> glbJsonChunk(const std::string& path, std::string_view bytes);

// tinygltf's image loader that decodes nothing: it keeps each image's bytes in the
// std::map<int, std::string> `user` points to, by image index (io/texture_loader.h decodes them
// when a material reads them).
bool keepGltfImageBytes(tinygltf::Image*, int image_index, std::string*, std::string*, int, int,
                        const unsigned char* bytes, int size, void* user);

// The corners of a primitive's triangles, three per triangle in the file's order, from its vertex
// sequence and mode (4 triangles, 5 strip, 6 fan; glTF 2.0 sec. 3.7.2.1: strip triangle i is
// (v_i, v_{i+1+i%2}, v_{i+2-i%2}), fan triangle i (v_{i+1}, v_{i+2}, v_0), the same triangle as
// (v_0, v_{i+1}, v_{i+2})). A list's last `seq.size() % 3` vertices are left out.
std::vector<uint32_t> gltfTriangleCorners(int mode, const std::vector<uint32_t>& seq);

}  // namespace penumbra
