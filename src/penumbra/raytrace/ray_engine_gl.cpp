#include "penumbra/raytrace/ray_engine_gl.h"
#include "raytrace/bindings.glsl"

#include "penumbra/core/check.h"
#include "penumbra/core/memory.h"
#include "penumbra/gpu/program.h"
#include "penumbra/raytrace/gpu_layout.h"

#include <glm/common.hpp>
#include <glm/vec4.hpp>

#include <fmt/format.h>
#include <algorithm>
#include <cmath>

namespace penumbra {

namespace {
constexpr GLuint kGroupSize = 64;  // local_size_x of bvh_intersect.comp (injected)
}

Expected<GlRayEngine> GlRayEngine::build(std::span<const glm::vec3> positions,
                                         std::span<const glm::uvec3> triangles,
                                         const BvhBuildOptions& options,
                                         const SurfaceTextures* cutouts) {
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
  std::vector<std::string> defines = bvhIntersectDefines();
  const bool filter = cutouts && cutouts->hasCutouts();
  if (filter) {
    Expected<GlCutouts> c =
        GlCutouts::create(buildGpuCutouts(*cutouts, triangles.size()), "the GPU Ray Engine");
    if (!c) return c.error();
    e.cutouts_ = std::move(*c);
    defines.push_back(cutoutDefine(RAY_ENGINE_SSBO_CUTOUTS));
  }
  Expected<gl::Program> program = gl::computeProgram("raytrace/bvh_intersect.comp", defines);
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
  glUniform1ui(gl::uniformLocation(program_.id(), "any_hit"), any_hit ? 1u : 0u);
  const GLint count_loc = gl::uniformLocation(program_.id(), "ray_count");
  nodes_.bindBase(GL_SHADER_STORAGE_BUFFER, RAY_ENGINE_SSBO_NODES);
  triangles_.bindBase(GL_SHADER_STORAGE_BUFFER, RAY_ENGINE_SSBO_TRIANGLES);
  ray_buf.bindBase(GL_SHADER_STORAGE_BUFFER, RAY_ENGINE_SSBO_RAYS);
  hit_buf.bindBase(GL_SHADER_STORAGE_BUFFER, RAY_ENGINE_SSBO_HITS);
  if (cutouts_) cutouts_->bind(RAY_ENGINE_SSBO_CUTOUTS);
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

Status GlRayEngine::traceResident(const gl::Buffer& rays, const gl::Buffer& hits, size_t count,
                                  bool any_hit) const {
  if (count == 0) return {};
  if (count > size_t(65535) * kGroupSize || int64_t(count * sizeof(GpuRay)) > max_ssbo_bytes_ ||
      rays.bytes() < count * sizeof(GpuRay) || hits.bytes() < count * sizeof(GpuHit)) {
    return runtimeError("", fmt::format("{} rays exceed one dispatch of the GPU kernel", count));
  }
  glUseProgram(program_.id());
  glUniform1ui(gl::uniformLocation(program_.id(), "any_hit"), any_hit ? 1u : 0u);
  glUniform1ui(gl::uniformLocation(program_.id(), "ray_count"), GLuint(count));
  nodes_.bindBase(GL_SHADER_STORAGE_BUFFER, RAY_ENGINE_SSBO_NODES);
  triangles_.bindBase(GL_SHADER_STORAGE_BUFFER, RAY_ENGINE_SSBO_TRIANGLES);
  rays.bindBase(GL_SHADER_STORAGE_BUFFER, RAY_ENGINE_SSBO_RAYS);
  hits.bindBase(GL_SHADER_STORAGE_BUFFER, RAY_ENGINE_SSBO_HITS);
  if (cutouts_) cutouts_->bind(RAY_ENGINE_SSBO_CUTOUTS);
  glDispatchCompute(GLuint((count + kGroupSize - 1) / kGroupSize), 1, 1);
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

namespace penumbra {

Expected<GlRasterKernel> GlRasterKernel::create(std::span<const glm::vec3> positions,
                                                std::span<const glm::uvec3> triangles, int tile,
                                                std::span<const uint32_t> order) {
  GlRasterKernel k;
  Expected<gl::Program> program =
      gl::renderProgram("raytrace/raster_intersect.vert", "raytrace/raster_intersect.frag");
  if (!program) return program.error();
  k.program_ = std::move(*program);
  k.tile_ = tile;
  k.triangle_count_ = uint32_t(triangles.size());
  std::vector<GpuTriangle> tris(triangles.size());
  k.slot_lo_.resize(triangles.size());
  k.slot_hi_.resize(triangles.size());
  glm::vec3 lo(INFINITY), hi(-INFINITY);
  for (size_t i = 0; i < triangles.size(); ++i) {
    const uint32_t src = order.empty() ? uint32_t(i) : order[i];
    const glm::vec3 p[3] = {positions[triangles[src].x], positions[triangles[src].y],
                            positions[triangles[src].z]};
    for (int a = 0; a < 3; ++a) {
      tris[i].p0[a] = p[0][a];
      tris[i].p1[a] = p[1][a];
      tris[i].p2[a] = p[2][a];
    }
    k.slot_lo_[i] = glm::min(glm::min(p[0], p[1]), p[2]);
    k.slot_hi_[i] = glm::max(glm::max(p[0], p[1]), p[2]);
    lo = glm::min(lo, k.slot_lo_[i]);
    hi = glm::max(hi, k.slot_hi_[i]);
    tris[i].id = int32_t(src);
    tris[i].pad1 = tris[i].pad2 = 0.0f;
  }
  k.box_lo_ = lo;
  k.box_hi_ = hi;
  k.triangles_ = gl::Buffer(std::max<size_t>(tris.size(), 1) * sizeof(GpuTriangle),
                            tris.empty() ? nullptr : tris.data(), 0);
  auto texture = [tile](GLenum format) {
    gl::Texture t = gl::createTexture(GL_TEXTURE_2D);
    glTextureStorage2D(t.id(), 1, format, tile, tile);
    glTextureParameteri(t.id(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTextureParameteri(t.id(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    return t;
  };
  k.origins_ = texture(GL_RGBA32F);
  k.directions_ = texture(GL_RGBA32F);
  k.id_target_ = texture(GL_R32I);
  k.tuv_target_ = texture(GL_RGBA32F);
  k.depth_ = gl::createRenderbuffer();
  glNamedRenderbufferStorage(k.depth_.id(), GL_DEPTH_COMPONENT32F, tile, tile);
  k.framebuffer_ = gl::createFramebuffer();
  glNamedFramebufferTexture(k.framebuffer_.id(), GL_COLOR_ATTACHMENT0, k.id_target_.id(), 0);
  glNamedFramebufferTexture(k.framebuffer_.id(), GL_COLOR_ATTACHMENT1, k.tuv_target_.id(), 0);
  glNamedFramebufferRenderbuffer(k.framebuffer_.id(), GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER,
                                 k.depth_.id());
  const GLenum buffers[] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
  glNamedFramebufferDrawBuffers(k.framebuffer_.id(), 2, buffers);
  if (glCheckNamedFramebufferStatus(k.framebuffer_.id(), GL_FRAMEBUFFER) !=
      GL_FRAMEBUFFER_COMPLETE) {
    return runtimeError("", "the ray engine's t-buffer framebuffer is incomplete on this device");
  }
  k.vao_ = gl::createVertexArray();
  return k;
}

namespace {

// Where the ray leaves the box, or -1 when it misses it within [tmin, tmax]; in double, widened
// slightly, so the bound never cuts off a hit on the box's surface.
float farBound(const Ray& r, const glm::vec3& lo, const glm::vec3& hi) {
  double t0 = r.tmin, t1 = r.tmax;
  for (int a = 0; a < 3; ++a) {
    const double o = r.origin[a], d = r.dir[a];
    if (d == 0.0) {
      if (o < lo[a] || o > hi[a]) return -1.0f;
      continue;
    }
    double ta = (double(lo[a]) - o) / d, tb = (double(hi[a]) - o) / d;
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb * (1.0 + 1e-6) + 1e-30);
  }
  if (t0 > t1) return -1.0f;
  return float(std::min(t1, double(r.tmax)));
}

}  // namespace

std::vector<std::string> bvhIntersectDefines() {
  return {fmt::format("MAX_BVH_DEPTH {}", kMaxBvhDepth),
          fmt::format("RAY_ENGINE_GROUP_SIZE {}", kGroupSize)};
}

Expected<GlRasterKernel::Job> GlRasterKernel::submit(const RayBatch& rays,
                                                     std::span<const uint32_t> ray_indices,
                                                     uint32_t first, uint32_t count) const {
  const size_t per_pass = size_t(tile_) * size_t(tile_);
  const size_t m = ray_indices.size();
  PENUMBRA_CHECK_MSG(m <= per_pass, "{} rays for a {}x{} tile", m, tile_, tile_);
  count = first < triangle_count_ ? std::min(count, triangle_count_ - first) : 0;
  std::vector<glm::vec4> origins(per_pass), directions(per_pass);
  for (size_t i = 0; i < per_pass; ++i) {
    if (i < m) {
      const Ray r = rays.get(ray_indices[i]);
      origins[i] = glm::vec4(r.origin, r.tmin);
      directions[i] = glm::vec4(r.dir, farBound(r, box_lo_, box_hi_));
    } else {
      origins[i] = glm::vec4(0.0f);
      directions[i] = glm::vec4(0.0f, 0.0f, 1.0f, -1.0f);  // no hit possible
    }
  }
  glTextureSubImage2D(origins_.id(), 0, 0, 0, tile_, tile_, GL_RGBA, GL_FLOAT, origins.data());
  glTextureSubImage2D(directions_.id(), 0, 0, 0, tile_, tile_, GL_RGBA, GL_FLOAT,
                      directions.data());
  glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_.id());
  glViewport(0, 0, tile_, tile_);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_TRUE);
  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);
  const GLint no_hit = -1;
  const GLfloat zero[4] = {0, 0, 0, 0};
  const GLfloat far_depth = 1.0f;
  glClearNamedFramebufferiv(framebuffer_.id(), GL_COLOR, 0, &no_hit);
  glClearNamedFramebufferfv(framebuffer_.id(), GL_COLOR, 1, zero);
  glClearNamedFramebufferfv(framebuffer_.id(), GL_DEPTH, 0, &far_depth);
  // The bound of where these rays can meet the pass's triangles, for the vertex stage's
  // culling (sec. 5.3), from exactly the values the fragment stage will see.
  glm::vec3 clip_lo(INFINITY), clip_hi(-INFINITY);
  for (uint32_t i = first; i < first + count; ++i) {
    clip_lo = glm::min(clip_lo, slot_lo_[i]);
    clip_hi = glm::max(clip_hi, slot_hi_[i]);
  }
  const RayBucketBound bound = boundRayBucket(std::span(origins.data(), m),
                                              std::span(directions.data(), m), clip_lo, clip_hi);
  if (count > 0) {
    glUseProgram(program_.id());
    glUniform1ui(gl::uniformLocation(program_.id(), "first_triangle"), first);
    setBucketBoundUniforms(program_.id(), bound);
    triangles_.bindBase(GL_SHADER_STORAGE_BUFFER, RAY_ENGINE_SSBO_TRIANGLES);
    glBindTextureUnit(RAY_ENGINE_TEXTURE_RAY_ORIGINS, origins_.id());
    glBindTextureUnit(RAY_ENGINE_TEXTURE_RAY_DIRECTIONS, directions_.id());
    glBindVertexArray(vao_.id());
    // Triangles in slot order: on equal depth the first drawn (lower slot) stays.
    glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, GLsizei(count));
    glBindVertexArray(0);
    glUseProgram(0);
  }
  // Results go to pack buffers; the copy runs on the GPU timeline, behind the fence.
  Job job;
  job.rays = m;
  job.bound = bound;
  job.ids = gl::Buffer(per_pass * 4, nullptr, GL_MAP_READ_BIT);
  job.tuv = gl::Buffer(per_pass * 16, nullptr, GL_MAP_READ_BIT);
  glBindBuffer(GL_PIXEL_PACK_BUFFER, job.ids.id());
  glGetTextureImage(id_target_.id(), 0, GL_RED_INTEGER, GL_INT, GLsizei(per_pass * 4), nullptr);
  glBindBuffer(GL_PIXEL_PACK_BUFFER, job.tuv.id());
  glGetTextureImage(tuv_target_.id(), 0, GL_RGBA, GL_FLOAT, GLsizei(per_pass * 16), nullptr);
  glBindBuffer(GL_PIXEL_PACK_BUFFER, 0);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  job.fence = gl::Fence::insert();
  glFlush();
  const GLenum err = glGetError();
  if (err != GL_NO_ERROR) {
    return runtimeError("", fmt::format("OpenGL error 0x{:x} in the ray engine kernel", err));
  }
  return job;
}

size_t GlRasterKernel::culledTriangles(const RayBucketBound& bound, uint32_t first,
                                       uint32_t count) const {
  count = first < triangle_count_ ? std::min(count, triangle_count_ - first) : 0;
  size_t culled = 0;
  for (uint32_t i = first; i < first + count; ++i) {
    culled += !bucketMayReach(bound, slot_lo_[i], slot_hi_[i]);
  }
  return culled;
}

void setBucketBoundUniforms(GLuint program, const RayBucketBound& b) {
  auto vec3 = [program](const char* name, const glm::vec3& v) {
    glUniform3f(gl::uniformLocation(program, name), v.x, v.y, v.z);
  };
  vec3("bucket.reach_lo", b.reach_lo);
  vec3("bucket.reach_hi", b.reach_hi);
  vec3("bucket.q0_lo", b.q0_lo);
  vec3("bucket.q0_hi", b.q0_hi);
  vec3("bucket.q1_lo", b.q1_lo);
  vec3("bucket.q1_hi", b.q1_hi);
  glUniform1i(gl::uniformLocation(program, "bucket.mode"), GLint(b.mode));
  glUniform1i(gl::uniformLocation(program, "bucket.axis"), b.axis);
  glUniform1f(gl::uniformLocation(program, "bucket.inv_length"), b.inv_length);
}

void GlRasterKernel::collect(Job& job, Hit* out) const {
  job.fence.wait();
  const auto* ids = static_cast<const int32_t*>(
      glMapNamedBufferRange(job.ids.id(), 0, GLsizeiptr(job.rays * 4), GL_MAP_READ_BIT));
  const auto* tuv = static_cast<const glm::vec4*>(
      glMapNamedBufferRange(job.tuv.id(), 0, GLsizeiptr(job.rays * 16), GL_MAP_READ_BIT));
  for (size_t k = 0; k < job.rays; ++k) {
    out[k] = ids[k] >= 0 ? Hit{ids[k], tuv[k].x, tuv[k].y, tuv[k].z} : Hit{};
  }
  glUnmapNamedBuffer(job.ids.id());
  glUnmapNamedBuffer(job.tuv.id());
}

Status GlRasterKernel::intersect(const RayBatch& rays, HitBatch& hits, uint32_t first,
                                 uint32_t count) const {
  const size_t n = rays.size();
  hits.resize(n);
  const size_t per_pass = size_t(tile_) * size_t(tile_);
  std::vector<uint32_t> indices(per_pass);
  std::vector<Hit> out(per_pass);
  for (size_t begin = 0; begin < n; begin += per_pass) {
    const size_t m = std::min(per_pass, n - begin);
    for (size_t i = 0; i < m; ++i) indices[i] = uint32_t(begin + i);
    Expected<Job> job = submit(rays, std::span(indices.data(), m), first, count);
    if (!job) return job.error();
    collect(*job, out.data());
    for (size_t i = 0; i < m; ++i) hits.set(begin + i, out[i]);
  }
  return {};
}

}  // namespace penumbra
