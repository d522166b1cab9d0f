#include "penumbra/subsurface/sss_gl.h"
#include "subsurface/sss_bindings.glsl"

#include "penumbra/core/check.h"
#include "penumbra/core/timer.h"
#include "penumbra/gpu/program.h"
#include "penumbra/raytrace/gpu_layout.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <variant>

namespace penumbra {

namespace {

constexpr uint32_t kGroup = 64;  // local_size_x of the subsurface shaders

GLuint groups(size_t n) {
  return GLuint((n + kGroup - 1) / kGroup);
}

void copy3(float* out, const glm::dvec3& v) {
  for (int c = 0; c < 3; ++c) out[c] = float(v[c]);
}

GpuMat3 gpuMat3(const glm::mat3& m) {
  GpuMat3 g{};
  for (int k = 0; k < 3; ++k) {
    for (int c = 0; c < 3; ++c) g.column[k][c] = m[k][c];
  }
  return g;
}

Status glCheck(const char* what) {
  const GLenum err = glGetError();
  if (err == GL_OUT_OF_MEMORY) {
    return runtimeError("",
                        fmt::format("subsurface passes on the GPU: out of device memory {}", what));
  }
  if (err != GL_NO_ERROR) {
    return runtimeError("", fmt::format("OpenGL error 0x{:x} {}", err, what));
  }
  return {};
}

}  // namespace

Expected<GlSss> GlSss::create(const SssSolver& solver) {
  while (glGetError() != GL_NO_ERROR) continue;  // earlier errors are not ours to report
  GlSss g;
  const RadiositySurface& s = solver.surface();
  const SssTree& t = solver.tree();
  const SssLinks& links = solver.links();
  const size_t n = s.elementCount();
  g.elements_count_ = n;
  g.links_per_element_ = links.per_element;
  g.shadows_ = solver.shadows();

  for (auto [program, pass] : {std::pair{&g.irradiance_rays_, 0}, {&g.irradiance_sum_, 1}}) {
    std::vector<std::string> defines = gpuLightDefines();
    defines.push_back(fmt::format("SSS_PASS {}", pass));
    Expected<gl::Program> p = gl::computeProgram("subsurface/sss_irradiance.comp", defines);
    if (!p) return p.error();
    *program = std::move(*p);
  }
  for (auto [program, name] : {std::pair{&g.mipmap_, "subsurface/sss_mipmap.comp"},
                               {&g.gather_, "subsurface/sss_gather.comp"}}) {
    Expected<gl::Program> p = gl::computeProgram(name);
    if (!p) return p.error();
    *program = std::move(*p);
  }
  // The lights' shadow rays pass through cut-outs as the CPU's do (raytrace/gpu_cutouts.h).
  Expected<GlRayEngine> engine =
      GlRayEngine::build(s.flat.positions, s.flat.triangles, {}, s.textures.get());
  if (!engine) return engine.error();
  g.engine_ = std::move(*engine);

  // Elements: what pass 1 reads (the CPU's values, in float).
  const std::vector<glm::vec3>& emitter = solver.staticIrradiance();
  std::vector<GpuSssElement> elements(n);
  for (size_t e = 0; e < n; ++e) {
    GpuSssElement& el = elements[e];
    copy3(el.position, s.atlas.element_position[e]);
    copy3(el.normal, s.atlas.element_normal[e]);
    copy3(el.shading_normal, s.shading_normal[e]);
    copy3(el.static_irradiance, glm::dvec3(emitter[e]));
    el.eta = solver.eta(e);
    el.lift = float(s.lift);
  }
  g.elements_ = gl::Buffer(n * sizeof(GpuSssElement), elements.data());

  // The tree, and its nodes in waves: a node's wave is one more than its children's latest.
  const size_t nodes = t.nodeCount();
  std::vector<GpuSssNode> node_data(nodes);
  std::vector<GpuMat3> moment(nodes);
  std::vector<uint32_t> wave(nodes, 0);
  uint32_t waves = 1;
  for (size_t k = 0; k < nodes; ++k) {
    GpuSssNode& nd = node_data[k];
    copy3(nd.position, t.position[k]);
    nd.area = float(t.area[k]);
    nd.child_first = t.child_first[k];
    nd.child_count = t.child_first[k + 1] - t.child_first[k];
    moment[k] = gpuMat3(t.moment_inverse[k]);
    // Children come before parents (SssTree), so their waves are known.
    for (uint32_t c : t.children(uint32_t(k))) wave[k] = std::max(wave[k], wave[c] + 1);
    waves = std::max(waves, wave[k] + 1);
  }
  std::vector<uint32_t> by_wave;
  g.wave_offset_.assign(waves + 1, 0);
  for (uint32_t w : wave) ++g.wave_offset_[w + 1];
  for (uint32_t w = 0; w < waves; ++w) g.wave_offset_[w + 1] += g.wave_offset_[w];
  by_wave.resize(nodes);
  std::vector<uint32_t> fill(g.wave_offset_.begin(), g.wave_offset_.end() - 1);
  for (size_t k = 0; k < nodes; ++k) by_wave[fill[wave[k]]++] = uint32_t(k);
  g.nodes_ = gl::Buffer(nodes * sizeof(GpuSssNode), node_data.data());
  g.children_ = gl::Buffer(t.child_index.size() * 4, t.child_index.data());
  g.wave_nodes_ = gl::Buffer(nodes * 4, by_wave.data());
  g.moment_inverse_ = gl::Buffer(nodes * sizeof(GpuMat3), moment.data());
  g.mean_ = gl::Buffer(nodes * 16, nullptr, 0);
  g.gradient_ = gl::Buffer(nodes * sizeof(GpuMat3), nullptr, GL_DYNAMIC_STORAGE_BIT);
  // Elements' gradients stay zero, as on the CPU.
  const float zero = 0.0f;
  glClearNamedBufferData(g.gradient_.id(), GL_R32F, GL_RED, GL_FLOAT, &zero);

  // The links.
  std::vector<GpuSssLink> link_data(links.node.size());
  for (size_t k = 0; k < link_data.size(); ++k) {
    GpuSssLink& l = link_data[k];
    for (int c = 0; c < 3; ++c) {
      l.factor[c] = links.factor[k][c];
      l.offset[c] = links.offset[k][c];
    }
    l.node = links.node[k];
  }
  g.links_ = gl::Buffer(link_data.size() * sizeof(GpuSssLink), link_data.data());
  g.scattered_ = gl::Buffer(n * 16, nullptr, 0);
  PENUMBRA_TRY(glCheck("uploading the subsurface links"));
  return g;
}

Status GlSss::frame(std::span<const Light> lights, std::vector<glm::vec3>& scattered,
                    SssPassTimes* times) {
  const size_t n = elements_count_;
  const size_t rays = n * lights.size();
  if (lights.size() > light_capacity_) {
    light_capacity_ = lights.size();
    lights_ = gl::Buffer(light_capacity_ * sizeof(GpuLight), nullptr);
    rays_ = gl::Buffer(n * light_capacity_ * sizeof(GpuRay), nullptr, 0);
    hits_ = gl::Buffer(n * light_capacity_ * sizeof(GpuHit), nullptr, 0);
    ray_values_ = gl::Buffer(n * light_capacity_ * 16, nullptr, 0);
  }
  Timer timer;
  auto lap = [&](double SssPassTimes::*slot) {
    if (!times) return;
    glFinish();
    times->*slot = timer.seconds();
    timer.reset();
  };

  // Pass 1.
  std::vector<float> tables;
  const std::vector<GpuLight> staged = gpuLights(lights, tables);
  if (!staged.empty()) lights_.upload(staged.data(), staged.size() * sizeof(GpuLight));
  if (tables != light_tables_data_) {  // the luminaires' LDTs go up when they change
    light_tables_data_ = std::move(tables);
    light_tables_ =
        gl::Buffer(light_tables_data_.size() * sizeof(float), light_tables_data_.data());
  }
  elements_.bindBase(GL_SHADER_STORAGE_BUFFER, SSS_SSBO_ELEMENTS);
  light_tables_.bindBase(GL_SHADER_STORAGE_BUFFER, SSS_SSBO_LIGHT_TABLES);
  if (rays > 0) {
    lights_.bindBase(GL_SHADER_STORAGE_BUFFER, SSS_SSBO_LIGHTS);
    rays_.bindBase(GL_SHADER_STORAGE_BUFFER, SSS_SSBO_RAYS);
    ray_values_.bindBase(GL_SHADER_STORAGE_BUFFER, SSS_SSBO_RAY_VALUES);
    glUseProgram(irradiance_rays_.id());
    glUniform1ui(gl::uniformLocation(irradiance_rays_.id(), "element_count"), GLuint(n));
    glUniform1ui(gl::uniformLocation(irradiance_rays_.id(), "light_count"), GLuint(lights.size()));
    glDispatchCompute(groups(rays), 1, 1);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
    if (shadows_) {
      PENUMBRA_TRY(engine_->traceResident(rays_, hits_, rays, true));
    } else {
      const int32_t none = -1;  // every GpuHit's triangle: unoccluded
      glClearNamedBufferData(hits_.id(), GL_R32I, GL_RED_INTEGER, GL_INT, &none);
    }
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
  }
  glUseProgram(irradiance_sum_.id());
  elements_.bindBase(GL_SHADER_STORAGE_BUFFER, SSS_SSBO_ELEMENTS);
  if (rays > 0) {
    hits_.bindBase(GL_SHADER_STORAGE_BUFFER, SSS_SSBO_HITS);
    ray_values_.bindBase(GL_SHADER_STORAGE_BUFFER, SSS_SSBO_RAY_VALUES);
  }
  mean_.bindBase(GL_SHADER_STORAGE_BUFFER, SSS_SSBO_MEAN);
  glUniform1ui(gl::uniformLocation(irradiance_sum_.id(), "element_count"), GLuint(n));
  glUniform1ui(gl::uniformLocation(irradiance_sum_.id(), "light_count"), GLuint(lights.size()));
  glDispatchCompute(groups(n), 1, 1);
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);

  // The MIP-map, wave by wave (wave 0 is the elements).
  glUseProgram(mipmap_.id());
  nodes_.bindBase(GL_SHADER_STORAGE_BUFFER, SSS_SSBO_NODES);
  children_.bindBase(GL_SHADER_STORAGE_BUFFER, SSS_SSBO_CHILDREN);
  wave_nodes_.bindBase(GL_SHADER_STORAGE_BUFFER, SSS_SSBO_WAVE_NODES);
  moment_inverse_.bindBase(GL_SHADER_STORAGE_BUFFER, SSS_SSBO_MOMENT_INVERSE);
  gradient_.bindBase(GL_SHADER_STORAGE_BUFFER, SSS_SSBO_GRADIENT);
  const GLint begin_loc = gl::uniformLocation(mipmap_.id(), "wave_begin");
  const GLint size_loc = gl::uniformLocation(mipmap_.id(), "wave_size");
  for (size_t w = 1; w + 1 < wave_offset_.size(); ++w) {
    const uint32_t size = wave_offset_[w + 1] - wave_offset_[w];
    glUniform1ui(begin_loc, wave_offset_[w]);
    glUniform1ui(size_loc, size);
    glDispatchCompute(groups(size), 1, 1);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
  }
  lap(&SssPassTimes::irradiance);

  // Pass 2.
  glUseProgram(gather_.id());
  links_.bindBase(GL_SHADER_STORAGE_BUFFER, SSS_SSBO_LINKS);
  scattered_.bindBase(GL_SHADER_STORAGE_BUFFER, SSS_SSBO_SCATTERED);
  glUniform1ui(gl::uniformLocation(gather_.id(), "element_count"), GLuint(n));
  glUniform1ui(gl::uniformLocation(gather_.id(), "links_per_element"), GLuint(links_per_element_));
  glDispatchCompute(groups(n), 1, 1);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  glUseProgram(0);
  std::vector<glm::vec4> b(n);
  if (n > 0) scattered_.download(b.data(), n * 16);
  scattered.resize(n);
  for (size_t e = 0; e < n; ++e) scattered[e] = glm::vec3(b[e]);
  lap(&SssPassTimes::gather);
  return glCheck("in the subsurface passes");
}

Status GlSss::downloadIrradiance(std::vector<glm::vec3>& irradiance) const {
  std::vector<glm::vec4> e(elements_count_);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  if (!e.empty()) mean_.download(e.data(), e.size() * 16);
  irradiance.resize(e.size());
  for (size_t k = 0; k < e.size(); ++k) irradiance[k] = glm::vec3(e[k]);
  return glCheck("reading back the transmitted irradiance");
}

}  // namespace penumbra
