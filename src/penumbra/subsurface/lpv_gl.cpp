#include "penumbra/subsurface/lpv_gl.h"
#include "subsurface/lpv_bindings.glsl"

#include "penumbra/gpu/program.h"
#include "penumbra/subsurface/lpv_sh.h"

#include <fmt/format.h>

#include <utility>

namespace penumbra {

namespace {

constexpr int kGroup = 4;  // local_size of lpv_propagate.comp along each axis

Status glCheck(const char* what) {
  const GLenum err = glGetError();
  if (err == GL_OUT_OF_MEMORY) {
    return runtimeError(
        "", fmt::format("light propagation volumes on the GPU: out of device memory {}", what));
  }
  if (err != GL_NO_ERROR) return runtimeError("", fmt::format("OpenGL error 0x{:x} {}", err, what));
  return {};
}

gl::Texture texture3D(GLenum format, const glm::ivec3& size) {
  gl::Texture t = gl::createTexture(GL_TEXTURE_3D);
  glTextureStorage3D(t.id(), 1, format, size.x, size.y, size.z);
  glTextureParameteri(t.id(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(t.id(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  return t;
}

void upload(const gl::Texture& t, const glm::ivec3& size, const std::vector<glm::vec4>& data) {
  glTextureSubImage3D(t.id(), 0, 0, 0, 0, size.x, size.y, size.z, GL_RGBA, GL_FLOAT, data.data());
}

}  // namespace

Expected<GlLpv> GlLpv::create() {
  while (glGetError() != GL_NO_ERROR) continue;  // earlier errors are not ours to report
  GlLpv g;
  Expected<gl::Program> p = gl::computeProgram("subsurface/lpv_propagate.comp");
  if (!p) return p.error();
  g.propagate_ = std::move(*p);
  // The matrices' six non-zero entries, from the same derivation as the CPU's (lpv_sh.h): +x
  // couples band 0 with y11 (index 3).
  const glm::dmat4& m = lpvPropagationMatrices()[0];
  const GLuint id = g.propagate_.id();
  glProgramUniform1f(id, gl::uniformLocation(id, "m00"), float(m[0][0]));
  glProgramUniform1f(id, gl::uniformLocation(id, "m0a"), float(m[3][0]));
  glProgramUniform1f(id, gl::uniformLocation(id, "ma0"), float(m[0][3]));
  glProgramUniform1f(id, gl::uniformLocation(id, "maa"), float(m[3][3]));
  glProgramUniform1f(id, gl::uniformLocation(id, "mbb"), float(m[1][1]));
  PENUMBRA_TRY(glCheck("compiling the propagation"));
  return g;
}

Status GlLpv::setVolume(size_t k, const LpvGrid& grid, std::span<const LpvCell> cells,
                        const LpvTransfer& transfer) {
  if (volumes_.size() <= k) volumes_.resize(k + 1);
  Volume& v = volumes_[k];
  if (v.size != grid.size) {
    v = Volume{};
    v.size = grid.size;
    v.cells = texture3D(GL_R8UI, grid.size);
    for (int ch = 0; ch < 3; ++ch) {
      v.scale[size_t(ch)] = texture3D(GL_RGBA32F, grid.size);
      v.accumulated[size_t(ch)] = texture3D(GL_RGBA32F, grid.size);
      for (auto& f : v.field) f[size_t(ch)] = texture3D(GL_RGBA32F, grid.size);
    }
  }
  static_assert(sizeof(LpvCell) == 1);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTextureSubImage3D(v.cells.id(), 0, 0, 0, 0, grid.size.x, grid.size.y, grid.size.z,
                      GL_RED_INTEGER, GL_UNSIGNED_BYTE, cells.data());
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  for (int ch = 0; ch < 3; ++ch) upload(v.scale[size_t(ch)], grid.size, transfer.scale[size_t(ch)]);
  return glCheck("uploading a volume");
}

Status GlLpv::propagate(size_t k, const LpvField& injected, int steps, int skip_steps,
                        LpvField& accumulated) {
  Volume& v = volumes_.at(k);
  const glm::ivec3 n = v.size;
  // Step 0: the injected field; the accumulation starts at zero.
  for (int ch = 0; ch < 3; ++ch) {
    upload(v.field[0][size_t(ch)], n, injected.c[size_t(ch)]);
    glClearTexImage(v.accumulated[size_t(ch)].id(), 0, GL_RGBA, GL_FLOAT, nullptr);
  }
  const GLuint id = propagate_.id();
  glUseProgram(id);
  glUniform3i(gl::uniformLocation(id, "size"), n.x, n.y, n.z);
  const GLint accumulate = gl::uniformLocation(id, "accumulate");
  glBindTextureUnit(LPV_TEX_CELLS, v.cells.id());
  for (int ch = 0; ch < 3; ++ch) {
    glBindTextureUnit(GLuint(LPV_TEX_SCALE + ch), v.scale[size_t(ch)].id());
    glBindImageTexture(GLuint(LPV_IMAGE_ACCUMULATED + ch), v.accumulated[size_t(ch)].id(), 0,
                       GL_TRUE, 0, GL_READ_WRITE, GL_RGBA32F);
  }
  for (int step = 1; step <= steps; ++step) {
    const auto& from = v.field[size_t((step - 1) & 1)];
    const auto& to = v.field[size_t(step & 1)];
    for (int ch = 0; ch < 3; ++ch) {
      glBindTextureUnit(GLuint(LPV_TEX_FROM + ch), from[size_t(ch)].id());
      glBindImageTexture(GLuint(LPV_IMAGE_TO + ch), to[size_t(ch)].id(), 0, GL_TRUE, 0,
                         GL_WRITE_ONLY, GL_RGBA32F);
    }
    glUniform1i(accumulate, step > skip_steps ? 1 : 0);
    glDispatchCompute(GLuint((n.x + kGroup - 1) / kGroup), GLuint((n.y + kGroup - 1) / kGroup),
                      GLuint((n.z + kGroup - 1) / kGroup));
    // The next step fetches what this one stored.
    glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
  }
  glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT);
  const size_t cells = size_t(n.x) * size_t(n.y) * size_t(n.z);
  for (int ch = 0; ch < 3; ++ch) {
    std::vector<glm::vec4>& out = accumulated.c[size_t(ch)];
    out.resize(cells);
    glGetTextureImage(v.accumulated[size_t(ch)].id(), 0, GL_RGBA, GL_FLOAT,
                      GLsizei(cells * sizeof(glm::vec4)), out.data());
  }
  return glCheck("propagating");
}

}  // namespace penumbra
