#include "penumbra/raytrace/ray_engine_gl.h"

#include "penumbra/core/memory.h"
#include "penumbra/gpu/program.h"
#include "penumbra/raytrace/gpu_layout.h"

#include <fmt/format.h>

namespace penumbra {

namespace {
constexpr GLuint kGroupSize = 64;  // local_size_x of bvh_intersect.comp
}

Expected<GlRayEngine> GlRayEngine::build(std::span<const glm::vec3> positions,
                                         std::span<const glm::uvec3> triangles,
                                         const BvhBuildOptions& options) {
  GlRayEngine e;
  GLint64 max_ssbo = 0;
  glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &max_ssbo);
  e.max_ssbo_bytes_ = max_ssbo;
  if (int64_t(triangles.size() * sizeof(GpuTriangle)) > max_ssbo) {
    return runtimeError(
        "", fmt::format("{} triangles need {} of GPU storage; this device allows "
                        "{} per buffer",
                        triangles.size(), formatBytes(triangles.size() * sizeof(GpuTriangle)),
                        formatBytes(uint64_t(max_ssbo))));
  }
  Expected<gl::Program> program = gl::computeProgram("raytrace/bvh_intersect.comp");
  if (!program) return program.error();
  e.program_ = std::move(*program);

  const Bvh bvh = buildBvh(positions, triangles, options);
  std::vector<GpuTriangle> tris(bvh.refs.size());
  for (size_t i = 0; i < bvh.refs.size(); ++i) {
    const glm::uvec3 t = triangles[bvh.refs[i]];
    GpuTriangle& g = tris[i];
    for (int k = 0; k < 3; ++k) {
      g.p0[k] = positions[t.x][k];
      g.p1[k] = positions[t.y][k];
      g.p2[k] = positions[t.z][k];
    }
    g.id = int32_t(bvh.refs[i]);
    g.pad1 = g.pad2 = 0.0f;
  }
  e.nodes_ = gl::Buffer(bvh.nodes.size() * sizeof(BvhNode), bvh.nodes.data(), 0);
  e.triangles_ = gl::Buffer(tris.size() * sizeof(GpuTriangle), tris.data(), 0);
  e.triangle_count_ = triangles.size();
  return e;
}

Status GlRayEngine::run(const RayBatch& rays, bool any_hit, std::vector<GpuHit>& out) const {
  const size_t n = rays.size();
  out.resize(n);
  if (n == 0) return {};
  // Rays go up in slices that fit the device's buffer limit and its dispatch limit.
  const size_t max_rays = size_t(
      std::min<int64_t>(max_ssbo_bytes_ / int64_t(sizeof(GpuRay)), int64_t(65535) * kGroupSize));
  const size_t slice = std::min(n, max_rays);
  std::vector<GpuRay> staging(slice);
  gl::Buffer ray_buf(slice * sizeof(GpuRay), nullptr);
  gl::Buffer hit_buf(slice * sizeof(GpuHit), nullptr);
  glUseProgram(program_.id());
  glUniform1ui(glGetUniformLocation(program_.id(), "any_hit"), any_hit ? 1u : 0u);
  const GLint count_loc = glGetUniformLocation(program_.id(), "ray_count");
  nodes_.bindBase(GL_SHADER_STORAGE_BUFFER, 0);
  triangles_.bindBase(GL_SHADER_STORAGE_BUFFER, 1);
  ray_buf.bindBase(GL_SHADER_STORAGE_BUFFER, 2);
  hit_buf.bindBase(GL_SHADER_STORAGE_BUFFER, 3);
  for (size_t begin = 0; begin < n; begin += slice) {
    const size_t m = std::min(slice, n - begin);
    for (size_t i = 0; i < m; ++i) {
      const size_t j = begin + i;
      staging[i] = GpuRay{{rays.ox[j], rays.oy[j], rays.oz[j]},
                          rays.tmin[j],
                          {rays.dx[j], rays.dy[j], rays.dz[j]},
                          rays.tmax[j]};
    }
    ray_buf.upload(staging.data(), m * sizeof(GpuRay));
    glUniform1ui(count_loc, GLuint(m));
    glDispatchCompute(GLuint((m + kGroupSize - 1) / kGroupSize), 1, 1);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    hit_buf.download(out.data() + begin, m * sizeof(GpuHit));
  }
  glUseProgram(0);
  const GLenum err = glGetError();
  if (err != GL_NO_ERROR)
    return runtimeError("", fmt::format("OpenGL error 0x{:x} while tracing", err));
  return {};
}

Status GlRayEngine::intersect(const RayBatch& rays, HitBatch& hits) const {
  std::vector<GpuHit> out;
  PENUMBRA_TRY(run(rays, false, out));
  hits.resize(out.size());
  for (size_t i = 0; i < out.size(); ++i) {
    hits.set(i, out[i].triangle >= 0 ? Hit{out[i].triangle, out[i].t, out[i].u, out[i].v} : Hit{});
  }
  return {};
}

Status GlRayEngine::occluded(const RayBatch& rays, std::vector<uint8_t>& occluded_out) const {
  std::vector<GpuHit> out;
  PENUMBRA_TRY(run(rays, true, out));
  occluded_out.resize(out.size());
  for (size_t i = 0; i < out.size(); ++i) occluded_out[i] = out[i].triangle >= 0 ? 1 : 0;
  return {};
}

}  // namespace penumbra
