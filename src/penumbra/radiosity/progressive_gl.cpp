#include "penumbra/radiosity/progressive_gl.h"
#include "radiosity/progressive_bindings.glsl"

#include "penumbra/core/check.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/timer.h"
#include "penumbra/gpu/program.h"
#include "penumbra/gpu/storage.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <glm/vec4.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <utility>

namespace penumbra {

namespace {

// Work-group sizes of shaders/radiosity/progressive.comp.
constexpr uint32_t kShooterGroup = 64;   // pass 0
constexpr uint32_t kPointGroup = 64;     // pass 2
constexpr uint32_t kResolveGroup = 256;  // pass 3
constexpr uint32_t kImageTile = 16;      // passes 4 and 5
constexpr uint32_t kMaxGroups = 65535;   // the minimum GL_MAX_COMPUTE_WORK_GROUP_COUNT

using gl::ceilDiv;

// A 1-D grid of `groups` work groups laid out as x * y with x <= kMaxGroups; the shaders
// number groups y * num_groups_x + x.
void dispatchLinear(uint32_t groups) {
  if (groups == 0) return;
  const uint32_t x = std::min(groups, kMaxGroups), y = ceilDiv(groups, kMaxGroups);
  glDispatchCompute(x, y, 1);
}

GLint uniform(const gl::Program& p, const char* name) {
  return gl::uniformLocation(p.id(), name);
}

// What create() needs of the CPU solver: the lights shot, the shooter level in range.
Status checkCpuSolver(const ProgressiveRadiosity& cpu, const char* place) {
  if (!cpu.lightsShot()) {
    return inputError(
        "", place,
        "the lights (point, spot, directional, luminaires) shoot first, on the CPU (shoot "
        "ProgressiveRadiosity::kLights before creating the GPU solver)");
  }
  if (cpu.options().shooter_level < 0 || cpu.options().shooter_level > 16) {
    return inputError("", place, "shooter_level must be in [0, 16]");
  }
  return {};
}

// The GL error state after the uploads of create(), as an error naming the bytes when out of
// memory.
Status uploadStatus(uint64_t device_bytes) {
  const GLenum err = glGetError();
  if (err == GL_OUT_OF_MEMORY) {
    return runtimeError("", fmt::format("progressive radiosity on the GPU: out of device memory "
                                        "for {} of textures and buffers",
                                        formatBytes(device_bytes)));
  }
  if (err != GL_NO_ERROR) {
    return runtimeError(
        "",
        fmt::format("OpenGL error 0x{:x} while uploading the progressive radiosity atlas", err));
  }
  return {};
}

}  // namespace

ProgressiveOptions gpuProgressiveOptions(ProgressiveOptions options) {
  options.shooter_top_points = 0;
  options.shading_normals = false;
  return options;
}

int gpuShooterLevel(const ProgressiveRadiosity& cpu, int points) {
  const double per_shooter =
      double(cpu.elementCount()) / double(std::max<size_t>(1, cpu.shooterCount()));
  int level = 0;
  while (level < 8 && per_shooter / std::pow(4.0, level + 1) >= double(std::max(points, 1))) {
    ++level;
  }
  return level;
}

Status GlProgressive::placeShooters(const ProgressiveRadiosity& cpu,
                                    std::vector<GpuShooter>& shooters,
                                    std::vector<GpuShooterPoint>& points,
                                    std::vector<glm::vec4>& polygons, const char* place) {
  const SurfaceHierarchy& hierarchy = cpu.hierarchy();
  const uint32_t ns = uint32_t(cpu.shooterCount());
  shooters.resize(ns);
  point_first_.assign(ns + 1, 0);
  point_max_area_.assign(ns, 0.0);
  shooter_elements_.resize(ns);
  shooter_normal_.resize(ns);
  shooter_closed_.resize(ns);
  shooter_centre_.resize(ns);
  shooter_radius_.resize(ns);
  uint32_t max_points = 0;
  for (uint32_t sh = 0; sh < ns; ++sh) {
    const uint32_t first = cpu.shooterBegin(sh), last = cpu.shooterEnd(sh);
    shooters[sh] = GpuShooter{first, last - first};
    shooter_elements_[sh] = glm::uvec2(first, last - first);
    const ClusterRef c = cpu.shooterCluster(sh);
    shooter_normal_[sh] = hierarchy.level(c.level).normal[c.index];
    shooter_closed_[sh] = cpu.shotClosed(sh) ? 1 : 0;
    glm::dvec3 centre = hierarchy.level(c.level).position[c.index];
    double radius = 0.0;
    for (uint32_t e = first; e < last; ++e) {
      radius = std::max(radius, glm::length(cpu.elementPosition(e) - centre));
    }
    shooter_centre_[sh] = centre;
    shooter_radius_[sh] = radius;
    point_first_[sh] = uint32_t(points.size());
    std::vector<std::array<glm::dvec3, 8>> pieces;
    std::vector<int> counts;
    for (const ClusterRef block : cpu.shooterBlocks(sh, cpu.flatLevel(sh))) {
      const uint32_t b0 = hierarchy.elementBegin(block), b1 = hierarchy.elementEnd(block);
      glm::dvec3 position(0.0);
      double area = 0.0;
      for (uint32_t e = b0; e < b1; ++e) {
        position += cpu.elementPosition(e) * cpu.elementArea(e);
        area += cpu.elementArea(e);
      }
      if (!(area > 0.0)) continue;
      // At level 0 a point is its element (its own point, not a mean of one).
      point_position_.push_back(b1 - b0 == 1 ? cpu.elementPosition(b0) : position / area);
      point_area_.push_back(area);
      point_members_.emplace_back(b0, b1 - b0);
      points.push_back(GpuShooterPoint{b0, b1 - b0});
      // Its pieces (an element's own at level 0, as the CPU's kMembers), 8 corners each, padded
      // by repeating the last.
      if (block.level == 0) {
        cpu.elementPieces(b0, pieces, counts);
      } else {
        cpu.clusterPieces(block, pieces, counts);
      }
      glm::uvec2 range(uint32_t(polygons.size() / 8), 0u);
      for (size_t q = 0; q < pieces.size(); ++q) {
        if (counts[q] < 3) continue;
        for (int k = 0; k < 8; ++k) {
          polygons.emplace_back(glm::vec3(pieces[q][size_t(std::min(k, counts[q] - 1))]), 0.0f);
        }
        ++range.y;
      }
      point_pieces_.push_back(range);
      point_max_area_[sh] = std::max(point_max_area_[sh], area);
    }
    max_points = std::max(max_points, uint32_t(points.size()) - point_first_[sh]);
  }
  point_first_[ns] = uint32_t(points.size());
  if (ceilDiv(max_points, kPointGroup) > kMaxGroups) {
    return inputError(
        "", place, fmt::format("{} points of one shooter exceed the dispatch limits", max_points));
  }
  return {};
}

Status GlProgressive::createGather(const ProgressiveRadiosity& cpu, size_t point_count,
                                   size_t point_corners, const char* place) {
  const size_t n = element_count_;
  const uint32_t ns = shooter_count_;
  const uint64_t texels = uint64_t(width_) * uint64_t(height_);
  const uint64_t groups = ceilDiv(std::max<size_t>(n, 1), kResolveGroup);
  const GlBufferNeed own[] = {
      {"texel-to-element map", texels * 4},
      {"element area", uint64_t(n) * 8},
      {"element coverage", uint64_t(n) * 8},
      {"shooter", uint64_t(ns) * sizeof(GpuShooter)},
      {"shooter point", uint64_t(point_count) * sizeof(GpuShooterPoint)},
      {"shooter point power", uint64_t(point_count) * 64},
      {"shooter point pieces", uint64_t(point_corners) * 16},
      {"shooter power", uint64_t(ns) * 32},
      {"resolve sums", groups * sizeof(GpuResolveSums)},
      // Coarse receivers (at most one per element) and the samples of subdivision.
      {"receiver", uint64_t(n) * (sizeof(GpuProgressiveElement) + 24)},
      {"subdivision sample", uint64_t(n) * 4},
  };
  // Radiosity, residual and two radiance atlases (RGBA32F).
  Expected<GlHemisphereGather> gather =
      GlHemisphereGather::create(cpu.surface(), gl_options_, options_.visibility, options_.adaptive,
                                 place, own, texels * 4 * 16);
  if (!gather) return gather.error();
  gather_ = std::move(*gather);
  device_bytes_ = gather_.deviceBytes();
  return {};
}

Status GlProgressive::compilePasses() {
  const char* pass_names[6] = {"power", "select", "points", "resolve", "radiance", "fill"};
  gl::Program* passes[6] = {&power_, &select_, &points_, &resolve_, &radiance_, &fill_};
  for (int pass = 0; pass < 6; ++pass) {
    Expected<gl::Program> p = gl::computeProgram("radiosity/progressive.comp",
                                                 {fmt::format("PROGRESSIVE_PASS {}", pass)});
    if (!p) {
      Error e = p.error();
      e.message = fmt::format("{} pass: {}", pass_names[pass], e.message);
      return e;
    }
    *passes[pass] = std::move(*p);
  }
  return {};
}

Expected<GlProgressive> GlProgressive::create(const ProgressiveRadiosity& cpu,
                                              const GlProgressiveOptions& gl_options) {
  const ProgressiveOptions& options = cpu.options();
  // Errors left by earlier work are not ours to report.
  while (glGetError() != GL_NO_ERROR) continue;
  const char* place = "progressive radiosity on the GPU";
  PENUMBRA_TRY(checkCpuSolver(cpu, place));

  GlProgressive s;
  s.options_ = options;
  s.gl_options_ = gl_options;
  const ChartAtlas& atlas = cpu.atlas();
  const size_t n = cpu.elementCount();
  const uint32_t ns = uint32_t(cpu.shooterCount());
  s.element_count_ = n;
  s.shooter_count_ = ns;
  s.width_ = atlas.width;
  s.height_ = atlas.height;

  // ---- Shooters and their points (the CPU's flat substructuring: clusters of one level) ----
  std::vector<GpuShooterPoint> points;
  std::vector<GpuShooter> shooters;
  std::vector<glm::vec4> point_polygons;
  PENUMBRA_TRY(s.placeShooters(cpu, shooters, points, point_polygons, place));

  // ---- The gather (depth maps and receiver passes), with this solver's own textures and
  // buffers in its one size and memory check ----
  PENUMBRA_TRY(s.createGather(cpu, points.size(), point_polygons.size(), place));

  // ---- Programs ----
  PENUMBRA_TRY(s.compilePasses());

  // ---- Per-element and per-texel data ----
  const uint64_t texels = uint64_t(atlas.width) * uint64_t(atlas.height);
  const uint64_t groups = ceilDiv(std::max<size_t>(n, 1), kResolveGroup);
  std::vector<double> element_area(n);
  std::vector<int32_t> texel_element(texels, -1);
  glm::dvec3 rho_area(0.0);
  std::vector<double> element_coverage(n);
  for (size_t e = 0; e < n; ++e) {
    element_area[e] = cpu.elementArea(e);
    element_coverage[e] = cpu.surface().coverageOf(e);
    texel_element[cpu.elementTexel(e)] = int32_t(e);
    s.total_area_ += cpu.elementArea(e);
    rho_area += cpu.reflectance(e) * cpu.elementArea(e);
  }
  s.ambient_factor_ =
      s.total_area_ > 0.0 ? 1.0 / (1.0 - rho_area / s.total_area_) : glm::dvec3(1.0);

  // ---- Buffers and textures ----
  s.shooters_ = gl::storageBuffer(shooters);
  s.element_area_ = gl::storageBuffer(element_area);
  s.element_coverage_ = gl::storageBuffer(element_coverage);
  s.texel_element_ = gl::storageBuffer(texel_element);
  s.points_buf_ = gl::storageBuffer(points);
  s.point_power_ = gl::Buffer(std::max<size_t>(points.size(), 1) * 64, nullptr, 0);
  if (point_polygons.empty()) point_polygons.emplace_back(0.0f);
  s.point_polygons_ = gl::storageBuffer(point_polygons);
  s.shooter_power_ = gl::Buffer(std::max<size_t>(ns, 1) * 32, nullptr, 0);
  s.selection_ = gl::Buffer(sizeof(GpuSelection), nullptr, 0);
  s.sums_ = gl::Buffer(size_t(groups) * sizeof(GpuResolveSums), nullptr, 0);
  s.samples_ = gl::Buffer(std::max<size_t>(n, 1) * 4, nullptr, GL_DYNAMIC_STORAGE_BIT);
  s.surface_ = &cpu.surface();
  s.receivers_ = cpu.receivers();
  s.radiosity_ = gl::texture2D(GL_RGBA32F, atlas.width, atlas.height);
  s.residual_ = gl::texture2D(GL_RGBA32F, atlas.width, atlas.height);
  for (gl::Texture& t : s.radiance_maps_) t = gl::texture2D(GL_RGBA32F, atlas.width, atlas.height);

  PENUMBRA_TRY(uploadStatus(s.device_bytes_));
  PENUMBRA_TRY(s.upload(cpu.state()));
  return s;
}

Status GlProgressive::glStatus(const char* what) const {
  const GLenum err = glGetError();
  if (err == GL_NO_ERROR) return {};
  if (err == GL_OUT_OF_MEMORY) {
    return runtimeError("", fmt::format("out of device memory while {}", what));
  }
  return runtimeError("", fmt::format("OpenGL error 0x{:x} while {}", err, what));
}

Status GlProgressive::upload(const ProgressiveState& state) {
  if (state.radiosity.size() != element_count_ || state.residual.size() != element_count_) {
    return inputError("", "progressive radiosity on the GPU",
                      fmt::format("the state has {} elements, the solver {}",
                                  state.radiosity.size(), element_count_));
  }
  if (state.iterations < 0) {
    return inputError("", "progressive radiosity on the GPU", "negative iterations");
  }
  if (!state.lights_shot) {
    return inputError("", "progressive radiosity on the GPU",
                      "the lights have not shot yet (they shoot on the CPU)");
  }
  const size_t texels = size_t(width_) * size_t(height_);
  std::vector<glm::vec4> b(texels, glm::vec4(0.0f)), db(texels, glm::vec4(0.0f));
  for (size_t e = 0; e < element_count_; ++e) {
    const glm::dvec3 &be = state.radiosity[e], &dbe = state.residual[e];
    for (int c = 0; c < 3; ++c) {
      if (!std::isfinite(be[c]) || !std::isfinite(dbe[c]) || be[c] < 0.0 || dbe[c] < 0.0) {
        return inputError("", "progressive radiosity on the GPU",
                          fmt::format("element {}: radiosity must be finite and >= 0", e));
      }
    }
    // Alpha 1 marks the occupied texels (sec. 3).
    b[gather_.elementTexel(e)] = glm::vec4(glm::vec3(be), 1.0f);
    db[gather_.elementTexel(e)] = glm::vec4(glm::vec3(dbe), 1.0f);
  }
  if (!state.receiver_levels.empty()) {
    Expected<ProgressiveReceivers> r =
        ProgressiveReceivers::fromElementLevels(*surface_, state.receiver_levels);
    if (!r) return r.error();
    receivers_ = std::move(*r);
  }
  if (!state.subdivided.empty()) {
    if (state.subdivided.size() != size_t(shooter_count_) + 1) {
      return inputError("", "progressive radiosity on the GPU",
                        fmt::format("the state has {} subdivision flags, the solver {}",
                                    state.subdivided.size(), shooter_count_ + 1));
    }
    subdivided_ = state.subdivided;
  }
  if (subdivided_.size() != size_t(shooter_count_) + 1) subdivided_.assign(shooter_count_ + 1, 0);
  uploadReceivers();
  glTextureSubImage2D(radiosity_.id(), 0, 0, 0, width_, height_, GL_RGBA, GL_FLOAT, b.data());
  glTextureSubImage2D(residual_.id(), 0, 0, 0, width_, height_, GL_RGBA, GL_FLOAT, db.data());
  balance_ = state.balance;
  iterations_ = state.iterations;
  return glStatus("uploading the progressive radiosity state");
}

Expected<ProgressiveState> GlProgressive::download() const {
  std::vector<glm::vec4> b, db;
  glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT);
  gl::readRGBA32F(radiosity_.id(), width_, height_, b);
  gl::readRGBA32F(residual_.id(), width_, height_, db);
  PENUMBRA_TRY(glStatus("reading back the progressive radiosity state"));
  ProgressiveState st;
  st.radiosity.resize(element_count_);
  st.residual.resize(element_count_);
  for (size_t e = 0; e < element_count_; ++e) {
    st.radiosity[e] = glm::dvec3(glm::vec3(b[gather_.elementTexel(e)]));
    st.residual[e] = glm::dvec3(glm::vec3(db[gather_.elementTexel(e)]));
  }
  st.balance = balance_;
  st.iterations = iterations_;
  st.lights_shot = true;
  st.receiver_levels = receivers_.elementLevels();
  st.subdivided = subdivided_;
  return st;
}

double GlProgressive::unshotFraction() const {
  return residualLuminance(balance_.unshot) / residualLuminance(balance_.emitted);
}

void GlProgressive::dispatchPower() {
  glUseProgram(power_.id());
  glUniform1ui(uniform(power_, "shooter_count"), shooter_count_);
  glUniform1i(uniform(power_, "atlas_width"), width_);
  shooters_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_SHOOTERS);
  gather_.elements().bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_ELEMENTS);
  shooter_power_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_SHOOTER_POWER);
  element_area_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_ELEMENT_AREA);
  glBindImageTexture(PROGRESSIVE_IMAGE_RESIDUAL, residual_.id(), 0, GL_FALSE, 0, GL_READ_ONLY,
                     GL_RGBA32F);
  dispatchLinear(ceilDiv(shooter_count_, kShooterGroup));
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
}

Expected<std::vector<double>> GlProgressive::residualPowers() {
  dispatchPower();
  std::vector<glm::dvec4> power(shooter_count_);
  if (shooter_count_ > 0) shooter_power_.download(power.data(), power.size() * 32);
  glUseProgram(0);
  PENUMBRA_TRY(glStatus("computing the residual powers"));
  std::vector<double> out(shooter_count_);
  for (uint32_t t = 0; t < shooter_count_; ++t) out[t] = power[t].w;
  return out;
}

Expected<uint32_t> GlProgressive::selectShooter() {
  dispatchPower();
  glUseProgram(select_.id());
  glUniform1ui(uniform(select_, "shooter_count"), shooter_count_);
  shooter_power_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_SHOOTER_POWER);
  selection_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_SELECTION);
  glDispatchCompute(1, 1, 1);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  glUseProgram(0);
  // The only read-back of the selection: the winner.
  GpuSelection sel{};
  selection_.download(&sel, sizeof(sel));
  PENUMBRA_TRY(glStatus("selecting the shooter"));
  return sel.power > 0.0 ? sel.shooter : kNoShooter;
}

void GlProgressive::uploadReceivers() {
  const size_t m = receivers_.size();
  const size_t nc = gather_.chartElements().size();
  chart_receivers_.assign(nc, glm::uvec2(0));
  if (receivers_.perElement()) {
    chart_receivers_ = gather_.chartElements();
    return;
  }
  const ChartAtlas& atlas = surface_->atlas;
  std::vector<GpuProgressiveElement> r(m);
  std::vector<double> position(3 * m);
  for (size_t k = 0; k < m; ++k) {
    GpuProgressiveElement& g = r[k];
    const glm::dvec3 p = receivers_.position(k);
    for (int c = 0; c < 3; ++c) {
      g.position[c] = float(p[c]);
      position[3 * k + size_t(c)] = p[c];
      g.reflectance[c] = 0.0f;  // receivers gather; the elements reflect (resolve pass)
      g.normal[c] = float(receivers_.normal(k)[c]);
      g.shading_normal[c] = float(receivers_.shadingNormal(k)[c]);
    }
    const ClusterRef cl = receivers_.cluster(k);
    g.area = float(surface_->hierarchy.level(cl.level).area[cl.index]);
    g.texel = gather_.elementTexel(receivers_.texelElement(k));
    g.triangle = atlas.faces[receivers_.face(k)].triangle;
    g.barycentric[0] = receivers_.barycentric(k).x;
    g.barycentric[1] = receivers_.barycentric(k).y;
    g.piece_first = 0;
    g.piece_count = 0;
    g.pad = 0;
    // Receivers are in element order: each chart's are one range.
    glm::uvec2& range = chart_receivers_[receivers_.chart(k)];
    if (range.y == 0) range.x = uint32_t(k);
    ++range.y;
  }
  receivers_buf_ = gl::storageBuffer(r);
  receiver_position_d_ = gl::storageBuffer(position);
}

Status GlProgressive::spreadIncident() {
  if (receivers_.perElement()) return {};
  std::vector<glm::vec4> rgba;
  glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT);
  gl::readRGBA32F(gather_.incident().id(), width_, height_, rgba);
  std::vector<glm::dvec3> gathered(receivers_.size());
  for (size_t k = 0; k < receivers_.size(); ++k) {
    gathered[k] = glm::dvec3(glm::vec3(rgba[gather_.elementTexel(receivers_.texelElement(k))]));
  }
  const std::vector<glm::dvec3> spread = receivers_.toElements(*surface_, std::move(gathered));
  std::fill(rgba.begin(), rgba.end(), glm::vec4(0.0f));
  for (size_t e = 0; e < element_count_; ++e) {
    rgba[gather_.elementTexel(e)] = glm::vec4(glm::vec3(spread[e]), 0.0f);
  }
  glTextureSubImage2D(gather_.incident().id(), 0, 0, 0, width_, height_, GL_RGBA, GL_FLOAT,
                      rgba.data());
  return glStatus("interpolating the receivers' irradiance");
}

void GlProgressive::drawReceivers(GlHemisphereGather::Pass pass, uint32_t first, uint32_t count,
                                  bool elements) {
  GlHemisphereGather::Receivers r;
  if (!elements && !receivers_.perElement()) r = {&receivers_buf_, &receiver_position_d_};
  gather_.draw(pass, first, count, r, residual_.id(), &samples_);
}

Expected<GpuResolveSums> GlProgressive::resolve(uint32_t shooter, const glm::dvec3& scale,
                                                bool apply) {
  const uint32_t groups = ceilDiv(std::max<size_t>(element_count_, 1), kResolveGroup);
  glUseProgram(resolve_.id());
  glUniform1ui(uniform(resolve_, "element_count"), uint32_t(element_count_));
  glUniform2ui(uniform(resolve_, "shooter_elements"), shooter_elements_[shooter].x,
               shooter_elements_[shooter].y);
  glUniform1i(uniform(resolve_, "atlas_width"), width_);
  glUniform3f(uniform(resolve_, "scale"), float(scale.x), float(scale.y), float(scale.z));
  glUniform1i(uniform(resolve_, "apply"), apply ? 1 : 0);
  gather_.elements().bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_ELEMENTS);
  sums_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_SUMS);
  element_area_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_ELEMENT_AREA);
  element_coverage_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_ELEMENT_COVERAGE);
  glBindImageTexture(PROGRESSIVE_IMAGE_RESIDUAL, residual_.id(), 0, GL_FALSE, 0, GL_READ_WRITE,
                     GL_RGBA32F);
  glBindImageTexture(PROGRESSIVE_IMAGE_RADIOSITY, radiosity_.id(), 0, GL_FALSE, 0, GL_READ_WRITE,
                     GL_RGBA32F);
  glBindTextureUnit(PROGRESSIVE_TEXTURE_INCIDENT_MAP, gather_.incident().id());
  dispatchLinear(groups);
  glMemoryBarrier(GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT |
                  GL_TEXTURE_UPDATE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT |
                  GL_SHADER_STORAGE_BARRIER_BIT);
  glUseProgram(0);
  std::vector<GpuResolveSums> sums(groups);
  sums_.download(sums.data(), sums.size() * sizeof(GpuResolveSums));
  PENUMBRA_TRY(glStatus("resolving the shot"));
  GpuResolveSums total{};
  for (const GpuResolveSums& g : sums) {
    for (int c = 0; c < 3; ++c) {
      total.arrived[c] += g.arrived[c];
      total.absorbed[c] += g.absorbed[c];
      total.reflected[c] += g.reflected[c];
    }
  }
  return total;
}

void GlProgressive::prepareBatch(const ActivePoints& active, uint32_t point_first, uint32_t first,
                                 uint32_t count) {
  std::array<GpuBatchPoint, kProgressiveBatchTiles * kProgressiveBatchTiles> points{};
  for (uint32_t k = 0; k < count; ++k) {
    const uint32_t p = active.index[first + k];
    GpuBatchPoint& b = points[k];
    for (int c = 0; c < 3; ++c) {
      b.position[c] = active.position[first + k][c];
      b.position_f[c] = float(active.position[first + k][c]);
      b.residual[c] = float(active.residual[first + k][c]);
    }
    b.position[3] = point_area_[p];
    b.position_f[3] = float(point_area_[p]);
    b.members[0] = point_members_[p].x;
    b.members[1] = point_members_[p].y;
    b.members[2] = p - point_first;
    b.pieces[0] = point_pieces_[p].x;
    b.pieces[1] = point_pieces_[p].y;
  }
  gather_.prepareBatch(std::span<const GpuBatchPoint>(points.data(), count));
}

Status GlProgressive::subdivide(uint32_t shooter, const ActivePoints& active,
                                const glm::dvec3& shot, ProgressiveIteration& it) {
  const Timer timer;
  subdivided_[shooter] = 1;
  const uint32_t point_first = point_first_[shooter];
  const uint32_t point_count = point_first_[shooter + 1] - point_first;
  const size_t n = element_count_;
  // The samples pass, once per batch: each element records its sample when its point is in
  // the batch (its point e mod point_count; points with nothing to shoot are in none, as on the
  // CPU, whose samples skip them).
  const uint32_t zero = 0;
  glClearNamedBufferData(samples_.id(), GL_R32UI, GL_RED_INTEGER, GL_UNSIGNED_INT, &zero);
  gather_.setSamplePoints(point_count);
  const uint32_t batch = gather_.batchSize();
  for (uint32_t first = 0; first < uint32_t(active.index.size()); first += batch) {
    const uint32_t count = std::min(batch, uint32_t(active.index.size()) - first);
    prepareBatch(active, point_first, first, count);
    drawReceivers(GlHemisphereGather::Pass::kSamples, 0, uint32_t(n), /*elements=*/true);
  }
  glUseProgram(0);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT);
  std::vector<uint32_t> bits(n);
  if (n > 0) samples_.download(bits.data(), n * 4);
  std::vector<glm::vec4> b;
  gl::readRGBA32F(radiosity_.id(), width_, height_, b);
  PENUMBRA_TRY(glStatus("counting the subdivision samples"));
  // The contrast test's shares, as the CPU solver computes them (the whole shooter as one disc).
  double area = 0.0;
  for (uint32_t p = point_first; p < point_first + point_count; ++p) area += point_area_[p];
  const glm::dvec3 mean_residual = area > 0.0 ? shot / area : glm::dvec3(0.0);
  std::vector<uint16_t> counted(n, 0), visible(n, 0);
  std::vector<float> share(n, 0.0f);
  for (size_t e = 0; e < n; ++e) {
    if (!receivers_.samples(e, options_.subdivision.finest_level) || !(bits[e] & 1u)) continue;
    counted[e] = 1;
    visible[e] = uint16_t((bits[e] >> 1) & 1u);
    const double irradiance = shooterDiscIrradiance(
        mean_residual, area, shooter_centre_[shooter], shooter_normal_[shooter],
        surface_->atlas.element_position[e], surface_->atlas.element_normal[e]);
    share[e] = float(subdivisionShare(irradiance, glm::dvec3(glm::vec3(b[gather_.elementTexel(e)])),
                                      surface_->emission[e], surface_->reflectance[e]));
  }
  it.refined = receivers_.subdivide(*surface_, counted, visible, share, options_.subdivision);
  uploadReceivers();
  it.subdivision_seconds = timer.seconds();
  return glStatus("uploading the receivers");
}

Expected<ProgressiveIteration> GlProgressive::shoot(uint32_t shooter) {
  PENUMBRA_CHECK_MSG(shooter < shooter_count_, "shooter {} of {}", shooter, shooter_count_);
  const Timer timer;
  ProgressiveIteration it;
  it.iteration = ++iterations_;
  it.shooter = shooter;
  const uint32_t point_first = point_first_[shooter];
  const uint32_t point_count = point_first_[shooter + 1] - point_first;

  // Shooter points: dB sums per cluster (substructuring, sec. 3), and their power-weighted
  // positions.
  std::vector<glm::dvec4> point_power(2 * size_t(point_count));
  if (point_count > 0) {
    glUseProgram(points_.id());
    glUniform1ui(uniform(points_, "point_first"), point_first);
    glUniform1ui(uniform(points_, "point_count"), point_count);
    glUniform1i(uniform(points_, "atlas_width"), width_);
    gather_.elements().bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_ELEMENTS);
    points_buf_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_POINTS);
    point_power_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_POINT_POWER);
    element_area_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_ELEMENT_AREA);
    glBindImageTexture(PROGRESSIVE_IMAGE_RESIDUAL, residual_.id(), 0, GL_FALSE, 0, GL_READ_ONLY,
                       GL_RGBA32F);
    glDispatchCompute(ceilDiv(point_count, kPointGroup), 1, 1);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
    glUseProgram(0);
    point_power_.download(point_power.data(), size_t(point_count) * 64, size_t(point_first) * 64);
  }
  glm::dvec3 shot(0.0);
  ActivePoints active;
  for (uint32_t k = 0; k < point_count; ++k) {
    const glm::dvec3 p(point_power[2 * k]);
    const glm::dvec4 moment = point_power[2 * k + 1];
    shot += p;
    if (p != glm::dvec3(0.0)) {
      active.index.push_back(point_first + k);
      active.residual.push_back(p / point_area_[point_first + k]);
      active.position.push_back(moment.w > 0.0 ? glm::dvec3(moment) / moment.w
                                               : point_position_[point_first + k]);
    }
  }
  it.shooter_points = uint32_t(active.index.size());

  if (!active.index.empty()) {
    gather_.setShooter(shooter_normal_[shooter], kProgressiveNear, kProgressiveFar);
    point_polygons_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_POINT_POLYGONS);
  }
  // Sec. 4 before the shooter's first shot: receivers split at its shadow boundaries, so that
  // the shot below gathers at the new ones.
  if (options_.adaptive && !subdivided_[shooter]) {
    PENUMBRA_TRY(subdivide(shooter, active, shot, it));
  }

  gather_.clearIncident();
  const std::vector<glm::uvec2> near_charts =
      gather_.nearCharts(shooter_centre_[shooter], shooter_radius_[shooter],
                         point_max_area_[shooter], kProgressiveNear, chart_receivers_);
  if (!active.index.empty()) {
    const uint32_t batch = gather_.batchSize();
    for (uint32_t first = 0; first < uint32_t(active.index.size()); first += batch) {
      const uint32_t count = std::min(batch, uint32_t(active.index.size()) - first);
      prepareBatch(active, point_first, first, count);
      // Far pairs over every receiver, near pairs over the charts that can have them.
      drawReceivers(GlHemisphereGather::Pass::kFar, 0, uint32_t(receivers_.size()));
      for (const glm::uvec2& c : near_charts) {
        drawReceivers(GlHemisphereGather::Pass::kNear, c.x, c.y);
      }
    }
    glUseProgram(0);
  }
  PENUMBRA_TRY(spreadIncident());

  // Closed shots arrive whole (ProgressiveRadiosity::shotClosed): the gathered irradiance
  // scaled so that the power arriving equals the power shot.
  glm::dvec3 scale(1.0);
  it.closed = shooter_closed_[shooter] != 0;
  if (it.closed) {
    Expected<GpuResolveSums> raw = resolve(shooter, glm::dvec3(1.0), false);
    if (!raw) return raw.error();
    for (int c = 0; c < 3; ++c) {
      if (raw->arrived[c] > 0.0) scale[c] = shot[c] / raw->arrived[c];
    }
  }
  // Resolve: B += rho E_in, dB += rho E_in, the shooter's dB = 0, and the energy sums.
  Expected<GpuResolveSums> sums = resolve(shooter, scale, true);
  if (!sums) return sums.error();
  PENUMBRA_TRY(glStatus("shooting"));

  // The books, exactly as the CPU keeps them (progressive.h).
  const glm::dvec3 arrived(sums->arrived[0], sums->arrived[1], sums->arrived[2]);
  const glm::dvec3 absorbed(sums->absorbed[0], sums->absorbed[1], sums->absorbed[2]);
  const glm::dvec3 reflected(sums->reflected[0], sums->reflected[1], sums->reflected[2]);
  balance_.absorbed += absorbed;
  balance_.unshot += reflected - shot;
  balance_.escaped += shot - arrived;

  it.shot_power = residualLuminance(shot);
  it.unshot_fraction = unshotFraction();
  it.rays = 0;  // visibility by depth maps
  it.seconds = timer.seconds();
  return it;
}

Expected<ProgressiveIteration> GlProgressive::step() {
  Expected<uint32_t> s = selectShooter();
  if (!s) return s.error();
  if (*s == kNoShooter) return ProgressiveIteration{};
  return shoot(*s);
}

Expected<ProgressiveStats> GlProgressive::solve(
    const std::function<void(const ProgressiveIteration&)>& after_iteration,
    const std::function<bool()>& stop) {
  return solveProgressively(
      options_, unshotFraction(), [&] { return step(); },
      [&]() -> Expected<bool> {
        Expected<uint32_t> s = selectShooter();
        if (!s) return s.error();
        return *s == kNoShooter;
      },
      [&] { return iterations_; }, after_iteration, stop);
}

Expected<Image> GlProgressive::radianceImage(bool with_ambient) {
  glm::dvec3 ambient(0.0);
  if (with_ambient && total_area_ > 0.0) {
    // Eq. 4-6: R * sum_j dB_j A_j / sum_k A_k, the unshot power from the power pass.
    dispatchPower();
    std::vector<glm::dvec4> power(shooter_count_);
    if (shooter_count_ > 0) shooter_power_.download(power.data(), power.size() * 32);
    glm::dvec3 unshot(0.0);
    for (const glm::dvec4& p : power) unshot += glm::dvec3(p);
    ambient = ambient_factor_ * unshot / total_area_;
  }
  const GLuint gx = ceilDiv(uint32_t(width_), kImageTile),
               gy = ceilDiv(uint32_t(height_), kImageTile);
  glUseProgram(radiance_.id());
  glUniform2i(uniform(radiance_, "atlas_size"), width_, height_);
  glUniform3f(uniform(radiance_, "ambient"), float(ambient.x), float(ambient.y), float(ambient.z));
  gather_.elements().bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_ELEMENTS);
  texel_element_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_TEXEL_ELEMENT);
  glBindImageTexture(PROGRESSIVE_IMAGE_RADIOSITY, radiosity_.id(), 0, GL_FALSE, 0, GL_READ_ONLY,
                     GL_RGBA32F);
  glBindImageTexture(PROGRESSIVE_IMAGE_RADIANCE, radiance_maps_[0].id(), 0, GL_FALSE, 0,
                     GL_WRITE_ONLY, GL_RGBA32F);
  glDispatchCompute(gx, gy, 1);
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
  // Sec. 3.1: ping-pong passes, each filling the unoccupied texels next to filled ones of the
  // same chart with their mean.
  int current = 0;
  glUseProgram(fill_.id());
  glUniform2i(uniform(fill_, "atlas_size"), width_, height_);
  gather_.texelChart().bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_TEXEL_CHART);
  for (int pass = 0; pass < gl_options_.gap_fill_passes; ++pass) {
    glBindTextureUnit(PROGRESSIVE_TEXTURE_SOURCE, radiance_maps_[size_t(current)].id());
    glBindImageTexture(PROGRESSIVE_IMAGE_TARGET, radiance_maps_[size_t(1 - current)].id(), 0,
                       GL_FALSE, 0, GL_WRITE_ONLY, GL_RGBA32F);
    glDispatchCompute(gx, gy, 1);
    glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
    current = 1 - current;
  }
  glUseProgram(0);
  glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT);
  const size_t texels = size_t(width_) * size_t(height_);
  std::vector<glm::vec4> rgba;
  gl::readRGBA32F(radiance_maps_[size_t(current)].id(), width_, height_, rgba);
  PENUMBRA_TRY(glStatus("computing the radiance atlas"));
  Image img(width_, height_);
  for (size_t i = 0; i < texels; ++i) img.pixels[i] = glm::vec3(rgba[i]);
  return img;
}

Expected<std::vector<uint32_t>> GlProgressive::receiverCoverage() {
  return gather_.coverage(residual_.id());
}

}  // namespace penumbra
