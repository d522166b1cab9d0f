// Small helpers the GPU solvers share: storage buffers from vectors, nearest-sampled 2D
// textures, band-wise read-back of RGBA32F textures, and whether the device is a software
// rasteriser (whose "device memory" is the machine's).
#pragma once

#include "penumbra/gpu/objects.h"

#include <glm/vec4.hpp>

#include <algorithm>
#include <cstdint>
#include <vector>

namespace penumbra::gl {

// A buffer holding `data` (at least one element's bytes, so that an empty range still binds).
template <typename T>
Buffer storageBuffer(const std::vector<T>& data, GLbitfield flags = GL_DYNAMIC_STORAGE_BIT) {
  return Buffer(std::max<size_t>(data.size(), 1) * sizeof(T), data.empty() ? nullptr : data.data(),
                flags);
}

// An immutable-storage 2D texture, nearest filtering, clamped.
Texture texture2D(GLenum format, int width, int height);

// Reads an RGBA32F texture in bands of rows (glGetTextureSubImage's size is a GLsizei).
void readRGBA32F(GLuint texture, int width, int height, std::vector<glm::vec4>& out);

// llvmpipe or softpipe: device memory is host memory.
bool softwareRenderer();

inline uint32_t ceilDiv(uint64_t a, uint64_t b) {
  return uint32_t((a + b - 1) / b);
}

}  // namespace penumbra::gl
