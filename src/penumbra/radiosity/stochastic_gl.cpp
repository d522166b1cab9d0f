#include "penumbra/radiosity/stochastic_gl.h"
#include "radiosity/stochastic_bindings.glsl"

#include "penumbra/gpu/program.h"
#include "penumbra/gpu/storage.h"

#include <fmt/format.h>
#include <glm/vec4.hpp>

#include <algorithm>

namespace penumbra {

namespace {

constexpr uint32_t kGroup = 256;        // shaders/radiosity/stochastic.comp, passes 0 and 1
constexpr uint32_t kMaxGroups = 65535;  // the minimum GL_MAX_COMPUTE_WORK_GROUP_COUNT
constexpr size_t kMaxLevels = 32;       // the shader's uniform arrays

// `count` invocations in groups of kGroup, as x * y groups (the shader numbers them y * x + x).
void dispatchCount(uint32_t count) {
  const uint32_t groups = (count + kGroup - 1) / kGroup;
  if (groups == 0) return;
  glDispatchCompute(std::min(groups, kMaxGroups), (groups + kMaxGroups - 1) / kMaxGroups, 1);
}

}  // namespace

Expected<GlStochasticSelection> GlStochasticSelection::create(const StochasticRadiosity& cpu) {
  const SurfaceHierarchy& h = cpu.surface().hierarchy;
  if (h.levelCount() > kMaxLevels) {
    return inputError(
        "", "stochastic radiosity on the GPU",
        fmt::format("a hierarchy of {} levels (at most {})", h.levelCount(), kMaxLevels));
  }
  GlStochasticSelection s;
  s.elements_ = cpu.elementCount();
  s.charts_ = uint32_t(h.chartCount());
  // Sums of all levels in one buffer, child ranges of the levels above 0 in another.
  std::vector<uint32_t> child_first;
  uint32_t sums = 0;
  for (size_t l = 0; l < h.levelCount(); ++l) {
    const ClusterLevel& lv = h.level(l);
    s.level_size_.push_back(uint32_t(lv.size()));
    s.level_offset_.push_back(sums);
    sums += uint32_t(lv.size());
    s.first_offset_.push_back(uint32_t(child_first.size()));
    if (l > 0) child_first.insert(child_first.end(), lv.child_first.begin(), lv.child_first.end());
  }
  std::vector<glm::uvec2> roots(s.charts_);
  for (uint32_t c = 0; c < s.charts_; ++c) {
    const ClusterRef r = h.root(c);
    roots[c] = glm::uvec2(r.level, r.index);
  }
  std::vector<double> area(cpu.atlas().element_area.begin(), cpu.atlas().element_area.end());
  s.area_ = gl::storageBuffer(area);
  s.child_first_ = gl::storageBuffer(child_first);
  s.roots_ = gl::storageBuffer(roots);
  s.sums_ = gl::Buffer(std::max<size_t>(sums, 1) * sizeof(double), nullptr, GL_DYNAMIC_STORAGE_BIT);
  s.iterate_ = gl::Buffer(std::max<size_t>(s.elements_, 1) * 32, nullptr, GL_DYNAMIC_STORAGE_BIT);
  s.selection_ = gl::Buffer(sizeof(GpuStochasticSelection), nullptr, GL_DYNAMIC_STORAGE_BIT);
  gl::Program* programs[3] = {&s.texels_, &s.level_, &s.descent_};
  for (int pass = 0; pass < 3; ++pass) {
    Expected<gl::Program> p =
        gl::computeProgram("radiosity/stochastic.comp", {fmt::format("STOCHASTIC_PASS {}", pass)});
    if (!p) return p.error();
    *programs[pass] = std::move(*p);
  }
  if (glGetError() != GL_NO_ERROR) {
    return runtimeError("", "stochastic radiosity on the GPU: OpenGL error while uploading");
  }
  return s;
}

Status GlStochasticSelection::upload(std::span<const glm::dvec3> radiosity) {
  if (radiosity.size() != elements_) {
    return inputError("", "stochastic radiosity on the GPU",
                      fmt::format("{} values for {} elements", radiosity.size(), elements_));
  }
  std::vector<glm::dvec4> b(elements_);
  for (size_t e = 0; e < elements_; ++e) b[e] = glm::dvec4(radiosity[e], 0.0);
  iterate_.upload(b.data(), b.size() * sizeof(glm::dvec4));
  return {};
}

Expected<GpuStochasticSelection> GlStochasticSelection::select(double u) {
  // Pass 0: the texels.
  glUseProgram(texels_.id());
  glUniform1ui(gl::uniformLocation(texels_.id(), "count"), uint32_t(elements_));
  iterate_.bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_ITERATE);
  area_.bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_AREA);
  sums_.bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_SUMS);
  dispatchCount(uint32_t(elements_));
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
  // Pass 1: each level from the one below.
  glUseProgram(level_.id());
  child_first_.bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_CHILD_FIRST);
  for (size_t l = 1; l < level_size_.size(); ++l) {
    glUniform1ui(gl::uniformLocation(level_.id(), "count"), level_size_[l]);
    glUniform1ui(gl::uniformLocation(level_.id(), "offset"), level_offset_[l]);
    glUniform1ui(gl::uniformLocation(level_.id(), "below_offset"), level_offset_[l - 1]);
    glUniform1ui(gl::uniformLocation(level_.id(), "first_offset"), first_offset_[l]);
    dispatchCount(level_size_[l]);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
  }
  // Pass 2: the descent, one invocation.
  glUseProgram(descent_.id());
  glUniform1ui(gl::uniformLocation(descent_.id(), "chart_count"), charts_);
  glUniform1d(gl::uniformLocation(descent_.id(), "u"), u);
  std::array<GLuint, kMaxLevels> level_offset{}, first_offset{};
  std::copy(level_offset_.begin(), level_offset_.end(), level_offset.begin());
  std::copy(first_offset_.begin(), first_offset_.end(), first_offset.begin());
  glUniform1uiv(gl::uniformLocation(descent_.id(), "level_offset[0]"), GLsizei(kMaxLevels),
                level_offset.data());
  glUniform1uiv(gl::uniformLocation(descent_.id(), "first_offset[0]"), GLsizei(kMaxLevels),
                first_offset.data());
  roots_.bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_ROOTS);
  selection_.bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_SELECTION);
  glDispatchCompute(1, 1, 1);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  glUseProgram(0);
  GpuStochasticSelection sel{};
  selection_.download(&sel, sizeof(sel));  // the only readback: 32 bytes
  const GLenum err = glGetError();
  if (err != GL_NO_ERROR) {
    return runtimeError("", fmt::format("OpenGL error 0x{:x} while selecting a shooter", err));
  }
  return sel;
}

}  // namespace penumbra
