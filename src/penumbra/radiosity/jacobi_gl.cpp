#include "penumbra/radiosity/jacobi_gl.h"
#include "radiosity/jacobi_bindings.glsl"

#include "penumbra/core/check.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/timer.h"
#include "penumbra/gpu/program.h"
#include "penumbra/gpu/storage.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <utility>

namespace penumbra {

namespace {

// The shader's copy of the layout constants (jacobi_layout.glsl).
std::vector<std::string> shaderDefines(int pass, bool fp16) {
  return {fmt::format("JACOBI_PASS {}", pass),
          fmt::format("JACOBI_FP16 {}", fp16 ? 1 : 0),
          fmt::format("BLOCK_COLUMNS {}u", kJacobiBlockColumns),
          fmt::format("LANES {}u", kJacobiLanes),
          fmt::format("WARPS {}u", kJacobiWarps),
          fmt::format("ROWS_PER_WARP {}u", kJacobiRowsPerWarp),
          fmt::format("UPDATE_GROUP {}u", kJacobiUpdateGroup),
          fmt::format("REDUCE_GROUP {}u", kJacobiReduceGroup)};
}

uint32_t ceilDiv(uint32_t a, uint32_t b) {
  return (a + b - 1) / b;
}

}  // namespace

Expected<GlJacobi> GlJacobi::create(const RadiositySystem& system, int64_t max_buffer_bytes) {
  // Errors left by earlier work are not ours to report.
  while (glGetError() != GL_NO_ERROR) continue;
  GlJacobi s;
  const uint32_t n = system.size();
  if (system.rowBegin() != 0 || system.rowEnd() != n) {
    return inputError("", "--device",
                      "the GPU Jacobi solver takes the whole matrix; over several ranks matrix "
                      "radiosity solves on the CPU (--device cpu)");
  }
  s.n_ = n;
  s.precision_ = system.precision();
  const bool fp16 = s.precision_ == MatrixPrecision::kFp16;
  s.blocks_ = ceilDiv(n, kJacobiBlockColumns);
  s.row_words_ = fp16 ? ceilDiv(n, 2) : n;

  // Every buffer must fit one shader storage block, and the grids the dispatch limits.
  GLint64 device_limit = 0;
  glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &device_limit);
  int64_t limit = device_limit;
  if (max_buffer_bytes > 0) limit = std::min(limit, max_buffer_bytes);
  limit = std::min<int64_t>(limit, int64_t(UINT32_MAX) * 4);  // the shaders index words by uint
  const uint64_t matrix_bytes = uint64_t(n) * s.row_words_ * 4;
  const uint64_t partial_bytes = uint64_t(s.blocks_) * n * sizeof(GpuRgb);
  const struct {
    const char* what;
    uint64_t bytes;
  } buffers[] = {{"form-factor matrix", matrix_bytes},
                 {"partial sums", partial_bytes},
                 {"element", uint64_t(n) * sizeof(GpuJacobiElement)}};
  for (const auto& b : buffers) {
    if (b.bytes > uint64_t(limit)) {
      return runtimeError(
          "", fmt::format("matrix radiosity on the GPU: the {} buffer of {} elements ({}) needs "
                          "{}, but this device allows {} per shader storage block "
                          "(GL_MAX_SHADER_STORAGE_BLOCK_SIZE); use fewer elements{}, or the CPU",
                          b.what, n, matrixPrecisionName(s.precision_), formatBytes(b.bytes),
                          formatBytes(uint64_t(limit)), fp16 ? "" : ", fp16 form factors"));
    }
  }
  GLint max_groups[2] = {0, 0};
  glGetIntegeri_v(GL_MAX_COMPUTE_WORK_GROUP_COUNT, 0, &max_groups[0]);
  glGetIntegeri_v(GL_MAX_COMPUTE_WORK_GROUP_COUNT, 1, &max_groups[1]);
  if (s.blocks_ > uint32_t(max_groups[0]) ||
      ceilDiv(n, kJacobiRowsPerGroup) > uint32_t(max_groups[1]) ||
      ceilDiv(n, kJacobiUpdateGroup) > uint32_t(max_groups[0])) {
    return runtimeError("", fmt::format("matrix radiosity on the GPU: {} elements exceed this "
                                        "device's compute dispatch limits",
                                        n));
  }
  // Device memory: what the device says it has free (NVIDIA), host memory for a software
  // renderer; everywhere else, GL_OUT_OF_MEMORY after allocating.
  const uint64_t total_bytes = matrix_bytes + partial_bytes +
                               uint64_t(n) * (sizeof(GpuJacobiElement) + 2 * sizeof(GpuRgb) + 8);
  if (gl::softwareRenderer()) {
    PENUMBRA_TRY(checkMemory(total_bytes, "matrix radiosity on a software OpenGL device"));
  } else if (epoxy_has_gl_extension("GL_NVX_gpu_memory_info")) {
    GLint free_kib = 0;
    glGetIntegerv(GL_GPU_MEMORY_INFO_CURRENT_AVAILABLE_VIDMEM_NVX, &free_kib);
    if (free_kib > 0 && total_bytes > uint64_t(free_kib) * 1024) {
      return runtimeError(
          "", fmt::format("matrix radiosity on the GPU needs {}; the device has {} "
                          "free",
                          formatBytes(total_bytes), formatBytes(uint64_t(free_kib) * 1024)));
    }
  }

  for (int pass = 0; pass < 3; ++pass) {
    Expected<gl::Program> p =
        gl::computeProgram("radiosity/jacobi.comp", shaderDefines(pass, fp16));
    if (!p) return p.error();
    (pass == 0 ? s.product_ : pass == 1 ? s.update_ : s.reduce_) = std::move(*p);
  }

  // F as stored by the CPU: the same bits, so both devices multiply by the same numbers.
  s.matrix_ = gl::Buffer(matrix_bytes, nullptr);
  if (!fp16) {
    if (n > 0) s.matrix_.upload(system.f32().data(), matrix_bytes);
  } else if (n % 2 == 0) {
    if (n > 0) s.matrix_.upload(system.f16().data(), matrix_bytes);  // little-endian pairs
  } else {
    // Odd N: each row is padded with one zero half to a whole number of words.
    const uint32_t zero = 0;
    glClearNamedBufferData(s.matrix_.id(), GL_R32UI, GL_RED_INTEGER, GL_UNSIGNED_INT, &zero);
    for (uint32_t i = 0; i < n; ++i) {
      s.matrix_.upload(system.f16().data() + size_t(i) * n, size_t(n) * 2,
                       size_t(i) * s.row_words_ * 4);
    }
  }
  s.partials_ = gl::Buffer(partial_bytes, nullptr, 0);
  s.elements_ = gl::Buffer(size_t(n) * sizeof(GpuJacobiElement), nullptr);
  s.row_residual_ = gl::Buffer(size_t(n) * sizeof(double), nullptr, 0);
  for (gl::Buffer& b : s.b_) b = gl::Buffer(size_t(n) * sizeof(GpuRgb), nullptr);
  // Two residual slots, persistently mapped: the CPU reads one behind a fence while the next
  // iteration writes the other.
  const GLbitfield map_flags = GL_MAP_READ_BIT | GL_MAP_PERSISTENT_BIT | GL_MAP_COHERENT_BIT;
  s.result_ = gl::Buffer(2 * sizeof(double), nullptr, map_flags);
  s.result_map_ = static_cast<const double*>(
      glMapNamedBufferRange(s.result_.id(), 0, 2 * sizeof(double), map_flags));
  const GLenum err = glGetError();
  if (err == GL_OUT_OF_MEMORY) {
    return runtimeError(
        "", fmt::format("matrix radiosity on the GPU: out of device memory for "
                        "{} of buffers ({} elements, {})",
                        formatBytes(total_bytes), n, matrixPrecisionName(s.precision_)));
  }
  if (err != GL_NO_ERROR || !s.result_map_) {
    return runtimeError(
        "", fmt::format("OpenGL error 0x{:x} while uploading the radiosity system", err));
  }

  s.self_form_factor_.resize(n);
  for (uint32_t i = 0; i < n; ++i) s.self_form_factor_[i] = system.formFactor(i, i);
  PENUMBRA_TRY(s.setMaterials(system.reflectance, system.emission));
  const std::vector<glm::vec3> zeros(n, glm::vec3(0.0f));
  PENUMBRA_TRY(s.upload(zeros));
  return s;
}

Status GlJacobi::setMaterials(std::span<const glm::vec3> reflectance,
                              std::span<const glm::vec3> emission) {
  PENUMBRA_CHECK_MSG(reflectance.size() == n_ && emission.size() == n_,
                     "{} reflectances and {} emissions for {} elements", reflectance.size(),
                     emission.size(), n_);
  std::vector<GpuJacobiElement> elements(n_);
  for (uint32_t i = 0; i < n_; ++i) {
    GpuJacobiElement& e = elements[i];
    for (int c = 0; c < 3; ++c) {
      e.reflectance[c] = reflectance[i][c];
      e.emission[c] = emission[i][c];
    }
    e.self_form_factor = self_form_factor_[i];
    e.pad = 0.0f;
  }
  if (n_ > 0) elements_.upload(elements.data(), elements.size() * sizeof(GpuJacobiElement));
  return glStatus("setting the radiosity materials");
}

Status GlJacobi::upload(std::span<const glm::vec3> b) {
  PENUMBRA_CHECK_MSG(b.size() == n_, "{} radiosities for {} elements", b.size(), n_);
  std::vector<GpuRgb> staging(n_);
  for (uint32_t i = 0; i < n_; ++i) staging[i] = GpuRgb{{b[i].x, b[i].y, b[i].z}, 0.0f};
  if (n_ > 0) b_[current_].upload(staging.data(), staging.size() * sizeof(GpuRgb));
  return glStatus("uploading the radiosities");
}

Status GlJacobi::download(std::vector<glm::vec3>& b) const {
  std::vector<GpuRgb> staging(n_);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  if (n_ > 0) b_[current_].download(staging.data(), staging.size() * sizeof(GpuRgb));
  b.resize(n_);
  for (uint32_t i = 0; i < n_; ++i)
    b[i] = glm::vec3(staging[i].rgb[0], staging[i].rgb[1], staging[i].rgb[2]);
  return glStatus("reading back the radiosities");
}

void GlJacobi::dispatch(int slot, bool advance) {
  const int next = 1 - current_;
  if (n_ > 0) {
    matrix_.bindBase(GL_SHADER_STORAGE_BUFFER, JACOBI_SSBO_MATRIX);
    b_[current_].bindBase(GL_SHADER_STORAGE_BUFFER, JACOBI_SSBO_RADIOSITY);
    partials_.bindBase(GL_SHADER_STORAGE_BUFFER, JACOBI_SSBO_PARTIALS);
    elements_.bindBase(GL_SHADER_STORAGE_BUFFER, JACOBI_SSBO_ELEMENTS);
    b_[next].bindBase(GL_SHADER_STORAGE_BUFFER, JACOBI_SSBO_NEXT);
    row_residual_.bindBase(GL_SHADER_STORAGE_BUFFER, JACOBI_SSBO_ROW_RESIDUAL);
    // Pass 1: the product, one group per (column block, tile of 32 rows).
    glUseProgram(product_.id());
    glUniform1ui(gl::uniformLocation(product_.id(), "n"), n_);
    if (precision_ == MatrixPrecision::kFp16) {  // fp32 rows are n floats: no such uniform
      glUniform1ui(gl::uniformLocation(product_.id(), "row_words"), row_words_);
    }
    glDispatchCompute(blocks_, ceilDiv(n_, kJacobiRowsPerGroup), 1);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
    // Pass 2: the partials summed in block order, eq. 4.
    glUseProgram(update_.id());
    glUniform1ui(gl::uniformLocation(update_.id(), "n"), n_);
    glUniform1ui(gl::uniformLocation(update_.id(), "blocks"), blocks_);
    glDispatchCompute(ceilDiv(n_, kJacobiUpdateGroup), 1, 1);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
  }
  // Pass 3: the sum of squared residuals into the slot (0 for an empty system).
  result_.bindBase(GL_SHADER_STORAGE_BUFFER, JACOBI_SSBO_RESULT);
  glUseProgram(reduce_.id());
  glUniform1ui(gl::uniformLocation(reduce_.id(), "n"), n_);
  glUniform1ui(gl::uniformLocation(reduce_.id(), "slot"), GLuint(slot));
  glDispatchCompute(1, 1, 1);
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_CLIENT_MAPPED_BUFFER_BARRIER_BIT);
  glUseProgram(0);
  result_fence_[size_t(slot)] = gl::Fence::insert();
  glFlush();
  if (advance) current_ = next;
}

double GlJacobi::readResidual(int slot) {
  result_fence_[size_t(slot)].wait();
  // meanSquaredResidual: the mean over elements and channels.
  return result_map_[slot] / (3.0 * double(std::max<uint32_t>(1, n_)));
}

Status GlJacobi::glStatus(const char* what) const {
  const GLenum err = glGetError();
  if (err == GL_NO_ERROR) return {};
  if (err == GL_OUT_OF_MEMORY) {
    return runtimeError("", fmt::format("out of device memory while {}", what));
  }
  return runtimeError("", fmt::format("OpenGL error 0x{:x} while {}", err, what));
}

Expected<double> GlJacobi::step() {
  dispatch(0, true);
  const double r = readResidual(0);
  PENUMBRA_TRY(glStatus("running a Jacobi iteration"));
  return r;
}

Expected<double> GlJacobi::residual() {
  dispatch(0, false);
  const double r = readResidual(0);
  PENUMBRA_TRY(glStatus("computing the radiosity residual"));
  return r;
}

Expected<SolveStats> GlJacobi::solve(std::vector<glm::vec3>& b, const SolveOptions& options,
                                     const std::function<void(int, double)>& after_iteration) {
  if (options.solver != MatrixSolver::kJacobi) {
    return inputError("", "",
                      fmt::format("the GPU matrix solver is Jacobi (Carr et al. 2003, sec. 3); "
                                  "{} is sequential and runs on the CPU",
                                  matrixSolverName(options.solver)));
  }
  const Timer timer;
  SolveStats stats;
  PENUMBRA_TRY(upload(b));
  // Iteration k + 1 is queued before the residual of iterate k is read, so the GPU never waits
  // for the CPU's convergence test. When iterate k turns out converged, the extra iteration is
  // dropped: it only read B_{k+1}, the iterate to return, and its residual is exactly the
  // final residual of B_{k+1}.
  bool lookahead_pending = false;
  if (options.max_iterations > 0) dispatch(0, true);
  for (int k = 0; k < options.max_iterations; ++k) {
    lookahead_pending = k + 1 < options.max_iterations;
    if (lookahead_pending) dispatch((k + 1) % 2, true);
    const double r = readResidual(k % 2);
    stats.history.push_back(r);  // residual of iterate k
    ++stats.iterations;
    if (after_iteration) after_iteration(k, r);
    if (r <= options.tolerance) break;
  }
  if (lookahead_pending) {
    current_ = 1 - current_;  // back to the iterate the dropped iteration started from
    stats.residual = readResidual(stats.iterations % 2);
  } else {
    dispatch(0, false);
    stats.residual = readResidual(0);
  }
  stats.history.push_back(stats.residual);
  stats.converged = stats.residual <= options.tolerance;
  PENUMBRA_TRY(glStatus("solving the radiosity system"));
  PENUMBRA_TRY(download(b));
  stats.seconds = timer.seconds();
  return stats;
}

}  // namespace penumbra
