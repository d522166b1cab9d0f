#include "penumbra/radiosity/stochastic_gl.h"
#include "radiosity/stochastic_bindings.glsl"

#include "penumbra/core/rng.h"
#include "penumbra/core/timer.h"
#include "penumbra/gpu/program.h"
#include "penumbra/gpu/storage.h"
#include "penumbra/radiosity/progressive.h"

#include <fmt/format.h>
#include <glm/vec2.hpp>
#include <glm/vec4.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <utility>

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

uint64_t GlStochasticSelection::deviceBytes(const StochasticRadiosity& cpu) {
  const SurfaceHierarchy& h = cpu.surface().hierarchy;
  uint64_t clusters = 0;
  for (size_t l = 0; l < h.levelCount(); ++l) clusters += h.level(l).size();
  // Iterate (32), area (8) per element; a sum (8) and a child_first entry (4) per cluster; a
  // root (8) per chart; the selection.
  return uint64_t(cpu.elementCount()) * 40 + clusters * 12 + uint64_t(h.chartCount()) * 8 +
         sizeof(GpuStochasticSelection);
}

void GlStochasticSelection::build() {
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
  glUseProgram(0);
}

Expected<GpuStochasticSelection> GlStochasticSelection::descend(double u) {
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
  sums_.bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_SUMS);
  child_first_.bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_CHILD_FIRST);
  iterate_.bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_ITERATE);
  roots_.bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_ROOTS);
  selection_.bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_SELECTION);
  glDispatchCompute(1, 1, 1);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  glUseProgram(0);
  GpuStochasticSelection sel{};
  selection_.download(&sel, sizeof(sel));  // the only readback: 64 bytes
  const GLenum err = glGetError();
  if (err != GL_NO_ERROR) {
    return runtimeError("", fmt::format("OpenGL error 0x{:x} while selecting a shooter", err));
  }
  return sel;
}

Expected<GpuStochasticSelection> GlStochasticSelection::select(double u) {
  build();
  return descend(u);
}

// ---- The solver ----

Expected<GlStochastic> GlStochastic::create(const StochasticRadiosity& cpu,
                                            const GlProgressiveOptions& gl_options) {
  // Errors left by earlier work are not ours to report.
  while (glGetError() != GL_NO_ERROR) continue;
  const char* place = "stochastic radiosity on the GPU";
  const size_t n = cpu.elementCount();
  const ChartAtlas& atlas = cpu.atlas();
  const uint64_t texels = uint64_t(atlas.width) * uint64_t(atlas.height);
  const uint64_t groups = gl::ceilDiv(std::max<size_t>(n, 1), kGroup);
  const GlBufferNeed own[] = {
      {"selection", GlStochasticSelection::deviceBytes(cpu)},
      {"source", uint64_t(n) * 32},
      {"running sum", uint64_t(n) * 64},
      {"error sums", groups * 16},
      {"local operator", uint64_t(cpu.local().size() + 1) * 8 + uint64_t(n + 1) * 4 + n * 32},
  };
  GlStochastic s;
  Expected<GlHemisphereGather> gather =
      GlHemisphereGather::create(cpu.surface(), gl_options, cpu.options().visibility,
                                 /*samples=*/false, place, own, texels * 16);
  if (!gather) return gather.error();
  s.gather_ = std::move(*gather);
  Expected<GlStochasticSelection> selection = GlStochasticSelection::create(cpu);
  if (!selection) return selection.error();
  s.selection_ = std::move(*selection);
  s.options_ = cpu.options();
  s.cpu_ = &cpu;
  s.elements_ = n;
  s.burn_in_ = cpu.burnIn();
  s.chart_elements_ = s.gather_.chartElements();
  for (const auto& [pass, program] :
       {std::pair{3, &s.update_}, std::pair{4, &s.error_}, std::pair{5, &s.local_}}) {
    Expected<gl::Program> p =
        gl::computeProgram("radiosity/stochastic.comp", {fmt::format("STOCHASTIC_PASS {}", pass)});
    if (!p) return p.error();
    *program = std::move(*p);
  }
  std::vector<glm::dvec4> source(n);
  // E' in xyz; w: the luminance of B_p - dB (the first shots), for the error estimate's mean.
  for (size_t e = 0; e < n; ++e) {
    source[e] = glm::dvec4(cpu.source(e), residualLuminance(cpu.shot(e)));
  }
  s.source_ = gl::storageBuffer(source);
  // The local operator (StochasticRadiosity::local): CSR rows, pairs as (element, factor bits).
  std::vector<uint32_t> first(n + 1);
  for (size_t e = 0; e <= n; ++e) first[e] = cpu.localBegin(e);
  std::vector<glm::uvec2> pairs(std::max<size_t>(cpu.local().size(), 1), glm::uvec2(0u));
  for (size_t k = 0; k < cpu.local().size(); ++k) {
    uint32_t bits = 0;
    std::memcpy(&bits, &cpu.local()[k].factor, 4);
    pairs[k] = glm::uvec2(cpu.local()[k].element, bits);
  }
  s.local_first_ = gl::storageBuffer(first);
  s.local_pairs_ = gl::storageBuffer(pairs);
  s.local_in_ = gl::Buffer(std::max<size_t>(n, 1) * sizeof(glm::dvec4), nullptr, 0);
  s.sums_ =
      gl::Buffer(std::max<size_t>(2 * n, 1) * sizeof(glm::dvec4), nullptr, GL_DYNAMIC_STORAGE_BIT);
  s.partial_ = gl::Buffer(size_t(groups) * 16, nullptr, 0);
  s.sent_ = gl::texture2D(GL_RGBA32F, atlas.width, atlas.height);
  PENUMBRA_TRY(s.glStatus("uploading the stochastic radiosity atlas"));
  PENUMBRA_TRY(s.upload(cpu.state()));
  return s;
}

Status GlStochastic::glStatus(const char* what) const {
  const GLenum err = glGetError();
  if (err == GL_NO_ERROR) return {};
  if (err == GL_OUT_OF_MEMORY) {
    return runtimeError("", fmt::format("out of device memory while {}", what));
  }
  return runtimeError("", fmt::format("OpenGL error 0x{:x} while {}", err, what));
}

Status GlStochastic::upload(const StochasticState& state) {
  const char* place = "stochastic radiosity on the GPU";
  const size_t n = elements_;
  if (state.iterate.size() != n || state.sum_odd.size() != n || state.sum_even.size() != n) {
    return inputError(
        "", place,
        fmt::format("the state has {} elements, the solver {}", state.iterate.size(), n));
  }
  if (state.iterations < 0) return inputError("", place, "negative iterations");
  std::vector<glm::dvec4> sums(2 * n);
  for (size_t e = 0; e < n; ++e) {
    for (const glm::dvec3* v : {&state.iterate[e], &state.sum_odd[e], &state.sum_even[e]}) {
      for (int c = 0; c < 3; ++c) {
        if (!std::isfinite((*v)[c]) || (*v)[c] < 0.0) {
          return inputError("", place,
                            fmt::format("element {}: radiosity must be finite and >= 0", e));
        }
      }
    }
    sums[e] = glm::dvec4(state.sum_even[e], 0.0);
    sums[n + e] = glm::dvec4(state.sum_odd[e], 0.0);
  }
  PENUMBRA_TRY(selection_.upload(state.iterate));
  if (n > 0) sums_.upload(sums.data(), sums.size() * sizeof(glm::dvec4));
  iterations_ = state.iterations;
  return glStatus("uploading the stochastic radiosity state");
}

Expected<StochasticState> GlStochastic::download() {
  const size_t n = elements_;
  std::vector<glm::dvec4> iterate(n), sums(2 * n);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  if (n > 0) {
    selection_.iterate().download(iterate.data(), n * sizeof(glm::dvec4));
    sums_.download(sums.data(), 2 * n * sizeof(glm::dvec4));
  }
  PENUMBRA_TRY(glStatus("reading back the stochastic radiosity state"));
  StochasticState st;
  st.iterate.resize(n);
  st.sum_even.resize(n);
  st.sum_odd.resize(n);
  for (size_t e = 0; e < n; ++e) {
    st.iterate[e] = glm::dvec3(iterate[e]);
    st.sum_even[e] = glm::dvec3(sums[e]);
    st.sum_odd[e] = glm::dvec3(sums[n + e]);
  }
  st.iterations = iterations_;
  return st;
}

void GlStochastic::shoot(const GpuStochasticSelection& sel, double weight) {
  const ChartAtlas& atlas = cpu_->surface().atlas;
  const uint32_t j = sel.element;
  const glm::dvec3 pj = atlas.element_position[j];
  const double aj = atlas.element_area[j];
  // Eq. 3: texel j sends B_j w / P_j.
  const glm::dvec3 sent =
      glm::dvec3(sel.value[0], sel.value[1], sel.value[2]) * (weight / sel.probability);
  const glm::vec4 texel(glm::vec3(sent), 1.0f);
  const uint32_t t = atlas.element_texel[j];
  glTextureSubImage2D(sent_.id(), 0, GLint(t % uint32_t(atlas.width)),
                      GLint(t / uint32_t(atlas.width)), 1, 1, GL_RGBA, GL_FLOAT, &texel);
  GpuBatchPoint point{};
  for (int c = 0; c < 3; ++c) {
    point.position[c] = pj[c];
    point.position_f[c] = float(pj[c]);
    point.residual[c] = float(sent[c]);
  }
  point.position[3] = aj;
  point.position_f[3] = float(aj);
  point.members[0] = j;
  point.members[1] = 1;
  gather_.setShooter(atlas.element_normal[j], kStochasticNear, kStochasticNear, kStochasticLocal);
  gather_.prepareBatch(std::span<const GpuBatchPoint>(&point, 1));
  // Far pairs over every element, near pairs (Lambert's exact form factor to j's pieces) over
  // the charts within reach.
  const GlHemisphereGather::Receivers elements{};
  gather_.draw(GlHemisphereGather::Pass::kFar, 0, uint32_t(elements_), elements, sent_.id());
  for (const glm::uvec2& c : gather_.nearCharts(pj, 0.0, aj, kStochasticNear, chart_elements_)) {
    gather_.draw(GlHemisphereGather::Pass::kNear, c.x, c.y, elements, sent_.id());
  }
  glUseProgram(0);
}

Expected<StochasticIteration> GlStochastic::step() {
  const Timer timer;
  StochasticIteration it;
  it.iteration = iterations_ + 1;
  // The CPU's random numbers for this iteration (StochasticRadiosity::step).
  Rng rng(mixBits(mixBits(options_.seed) ^ uint64_t(it.iteration)), 0x5eedu);
  const double weight = 1.0 / double(options_.shooters);
  // Every shooter of the iteration from B_{m-1}: the sums once, a descent per shooter.
  selection_.build();
  gather_.clearIncident();
  for (int k = 0; k < options_.shooters; ++k) {
    const double u = double(rng.nextU32()) * 0x1p-32 + double(rng.nextU32()) * 0x1p-64;
    Expected<GpuStochasticSelection> sel = selection_.descend(u);
    if (!sel) return sel.error();
    if (!sel->found && k == 0) it.power = 0.0;
    if (!sel->found) continue;  // an iterate without light sends nothing: T* 0 = 0
    if (!(sel->probability > 0.0)) {
      return runtimeError("", "stochastic radiosity on the GPU: the iterate holds no light");
    }
    if (k == 0) {
      it.shooter = sel->element;
      it.power = sel->power;
    }
    shoot(*sel, weight);
  }
  // The local operator from B_{m-1}, then the update: B_m = E' + rho (E_local + E_in), and
  // eq. 2's sums after the burn-in.
  glUseProgram(local_.id());
  glUniform1ui(gl::uniformLocation(local_.id(), "count"), uint32_t(elements_));
  local_first_.bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_LOCAL_FIRST);
  local_pairs_.bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_LOCAL);
  selection_.iterate().bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_ITERATE);
  local_in_.bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_LOCAL_IN);
  dispatchCount(uint32_t(elements_));
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
  ++iterations_;
  const int sum_index = averaged() > 0 ? (averaged() & 1) : -1;
  glUseProgram(update_.id());
  glUniform1ui(gl::uniformLocation(update_.id(), "count"), uint32_t(elements_));
  glUniform1i(gl::uniformLocation(update_.id(), "atlas_width"), gather_.width());
  glUniform1i(gl::uniformLocation(update_.id(), "sum_index"), sum_index);
  gather_.elements().bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_ELEMENTS);
  source_.bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_SOURCE);
  selection_.iterate().bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_ITERATE);
  sums_.bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_AVERAGE);
  local_in_.bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_LOCAL_IN);
  glBindTextureUnit(STOCHASTIC_TEXTURE_INCIDENT, gather_.incident().id());
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_FRAMEBUFFER_BARRIER_BIT);
  dispatchCount(uint32_t(elements_));
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
  glUseProgram(0);
  PENUMBRA_TRY(glStatus("iterating"));
  it.rays = 0;  // visibility by depth maps
  it.seconds = timer.seconds();
  return it;
}

Expected<StochasticStats> GlStochastic::solve(
    const std::function<void(const StochasticIteration&)>& after,
    const std::function<bool()>& stop) {
  Expected<StochasticStats> st = iterateStochastic(
      options_, [&] { return iterations_; }, [&] { return step(); }, after, stop);
  if (!st) return st.error();
  Expected<double> error = errorEstimate();
  if (!error) return error.error();
  st->error = *error;
  return st;
}

Expected<double> GlStochastic::errorEstimate() {
  const int odd = (averaged() + 1) / 2, even = averaged() / 2;
  if (odd == 0 || even == 0) return 1.0;
  const uint32_t groups = gl::ceilDiv(std::max<size_t>(elements_, 1), kGroup);
  glUseProgram(error_.id());
  glUniform1ui(gl::uniformLocation(error_.id(), "count"), uint32_t(elements_));
  glUniform1d(gl::uniformLocation(error_.id(), "odd"), double(odd));
  glUniform1d(gl::uniformLocation(error_.id(), "even"), double(even));
  selection_.area().bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_AREA);
  sums_.bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_AVERAGE);
  partial_.bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_PARTIAL);
  source_.bindBase(GL_SHADER_STORAGE_BUFFER, STOCHASTIC_SSBO_SOURCE);
  dispatchCount(uint32_t(elements_));
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  glUseProgram(0);
  std::vector<glm::dvec2> part(groups);
  partial_.download(part.data(), part.size() * sizeof(glm::dvec2));
  PENUMBRA_TRY(glStatus("estimating the error"));
  glm::dvec2 sum(0.0);
  for (const glm::dvec2& p : part) sum += p;
  return sum.y > 0.0 ? std::sqrt(sum.x / sum.y) : 0.0;
}

Expected<std::vector<glm::dvec3>> GlStochastic::radiosity() {
  Expected<StochasticState> st = download();
  if (!st) return st.error();
  std::vector<glm::dvec3> out(elements_);
  for (size_t e = 0; e < elements_; ++e) {
    out[e] =
        cpu_->shot(e) + (averaged() == 0 ? st->iterate[e]
                                         : (st->sum_odd[e] + st->sum_even[e]) / double(averaged()));
  }
  return out;
}

Expected<Image> GlStochastic::radianceImage() {
  Expected<std::vector<glm::dvec3>> b = radiosity();
  if (!b) return b.error();
  return cpu_->surface().radianceImage(*b);
}

}  // namespace penumbra
