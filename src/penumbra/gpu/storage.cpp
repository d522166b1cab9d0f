#include "penumbra/gpu/storage.h"

#include <cstring>

namespace penumbra::gl {

Texture texture2D(GLenum format, int width, int height) {
  Texture t = createTexture(GL_TEXTURE_2D);
  glTextureStorage2D(t.id(), 1, format, width, height);
  glTextureParameteri(t.id(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(t.id(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glTextureParameteri(t.id(), GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTextureParameteri(t.id(), GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  return t;
}

void readRGBA32F(GLuint texture, int width, int height, std::vector<glm::vec4>& out) {
  out.resize(size_t(width) * size_t(height));
  const size_t row_bytes = size_t(width) * sizeof(glm::vec4);
  const int band = int(std::max<size_t>(1, (size_t(1) << 30) / row_bytes));
  for (int y = 0; y < height; y += band) {
    const int rows = std::min(band, height - y);
    glGetTextureSubImage(texture, 0, 0, y, 0, width, rows, 1, GL_RGBA, GL_FLOAT,
                         GLsizei(row_bytes * size_t(rows)), out.data() + size_t(y) * size_t(width));
  }
}

bool softwareRenderer() {
  const auto* renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  return renderer && (std::strstr(renderer, "llvmpipe") || std::strstr(renderer, "softpipe"));
}

}  // namespace penumbra::gl
