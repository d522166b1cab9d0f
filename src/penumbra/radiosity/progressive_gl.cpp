#include "penumbra/radiosity/progressive_gl.h"
#include "radiosity/progressive_bindings.glsl"

#include "penumbra/core/check.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/timer.h"
#include "penumbra/gpu/program.h"

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
constexpr int kMaxTessellation = 64;     // sub-triangle grid per triangle (code: 8 bits each)
// Points closer to the shooter's plane than this fraction of the far plane count as on it (the
// float rounding of coplanar geometry; the CPU lifts its shadow rays by 1e-5 of the scene too).
constexpr float kOnPlane = 1e-5f;
constexpr int kMaxTiles = kProgressiveBatchTiles;
static_assert(kMaxTiles * kMaxTiles == 16, "MAX_BATCH_POINTS in progressive_layout.glsl");

uint32_t ceilDiv(uint64_t a, uint64_t b) {
  return uint32_t((a + b - 1) / b);
}

// A 1-D grid of `groups` work groups laid out as x * y with x <= kMaxGroups; the shaders
// number groups y * num_groups_x + x.
void dispatchLinear(uint32_t groups) {
  if (groups == 0) return;
  const uint32_t x = std::min(groups, kMaxGroups), y = ceilDiv(groups, kMaxGroups);
  glDispatchCompute(x, y, 1);
}

bool softwareRenderer() {
  const auto* renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  return renderer && (std::strstr(renderer, "llvmpipe") || std::strstr(renderer, "softpipe"));
}

GLint uniform(const gl::Program& p, const char* name) {
  return gl::uniformLocation(p.id(), name);
}

// Any orthonormal frame around the unit normal n: the image axes of the hemisphere.
void hemisphereFrame(const glm::dvec3& n, glm::dvec3& tangent, glm::dvec3& bitangent) {
  const glm::dvec3 a = std::abs(n.x) < 0.9 ? glm::dvec3(1.0, 0.0, 0.0) : glm::dvec3(0.0, 1.0, 0.0);
  tangent = glm::normalize(glm::cross(n, a));
  bitangent = glm::cross(n, tangent);
}

// The hemisphere uniforms shared by a shooter's points: the frame around its normal, the far
// plane and the on-plane tolerance (the origin is each point's, read by the shaders).
void setHemisphere(const gl::Program& p, const glm::dvec3& normal, float far) {
  glm::dvec3 t, b;
  hemisphereFrame(normal, t, b);
  const GLuint id = p.id();
  glProgramUniform3f(id, uniform(p, "hemisphere.tangent"), float(t.x), float(t.y), float(t.z));
  glProgramUniform3f(id, uniform(p, "hemisphere.bitangent"), float(b.x), float(b.y), float(b.z));
  glProgramUniform3f(id, uniform(p, "hemisphere.normal"), float(normal.x), float(normal.y),
                     float(normal.z));
  glProgramUniform1f(id, uniform(p, "hemisphere.inv_far"), 1.0f / far);
  glProgramUniform1f(id, uniform(p, "hemisphere.on_plane"), kOnPlane * far);
}

template <typename T>
gl::Buffer makeBuffer(const std::vector<T>& data, GLbitfield flags = GL_DYNAMIC_STORAGE_BIT) {
  return gl::Buffer(std::max<size_t>(data.size(), 1) * sizeof(T),
                    data.empty() ? nullptr : data.data(), flags);
}

gl::Texture makeTexture(GLenum format, int width, int height) {
  gl::Texture t = gl::createTexture(GL_TEXTURE_2D);
  glTextureStorage2D(t.id(), 1, format, width, height);
  glTextureParameteri(t.id(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(t.id(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glTextureParameteri(t.id(), GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTextureParameteri(t.id(), GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  return t;
}

// The depth pass's sub-triangle grid of a triangle `leg` atlas texels across: k x k
// sub-triangles with legs of about `texels` texels.
int tessellation(int leg, int texels) {
  return std::clamp((leg + texels - 1) / texels, 1, kMaxTessellation);
}

// Reads an RGBA32F texture in bands of rows (glGetTextureSubImage's size is a GLsizei).
void readTexture(GLuint texture, int width, int height, std::vector<glm::vec4>& out) {
  out.resize(size_t(width) * size_t(height));
  const size_t row_bytes = size_t(width) * sizeof(glm::vec4);
  const int band = int(std::max<size_t>(1, (size_t(1) << 30) / row_bytes));
  for (int y = 0; y < height; y += band) {
    const int rows = std::min(band, height - y);
    glGetTextureSubImage(texture, 0, 0, y, 0, width, rows, 1, GL_RGBA, GL_FLOAT,
                         GLsizei(row_bytes * size_t(rows)), out.data() + size_t(y) * size_t(width));
  }
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

Expected<GlProgressive> GlProgressive::create(const ProgressiveRadiosity& cpu,
                                              const GlProgressiveOptions& gl_options) {
  const ProgressiveOptions& options = cpu.options();
  // Errors left by earlier work are not ours to report.
  while (glGetError() != GL_NO_ERROR) continue;
  const char* place = "progressive radiosity on the GPU";
  if (!cpu.lightsShot()) {
    return inputError(
        "", place,
        "the lights (point, spot, directional, luminaires) shoot first, on the CPU (shoot "
        "ProgressiveRadiosity::kLights before creating the GPU solver)");
  }
  if (gl_options.visibility_resolution < 16) {
    return inputError("", place, "the visibility resolution must be at least 16 texels");
  }
  if (gl_options.tessellation_texels < 1) {
    return inputError("", place, "tessellation_texels must be at least 1");
  }
  if (gl_options.gap_fill_passes < 0 || !(gl_options.depth_tolerance >= 0.0f)) {
    return inputError("", place, "gap_fill_passes and depth_tolerance must not be negative");
  }
  if (options.shooter_level < 0 || options.shooter_level > 16) {
    return inputError("", place, "shooter_level must be in [0, 16]");
  }

  GlProgressive s;
  s.options_ = options;
  s.gl_options_ = gl_options;
  const ChartAtlas& atlas = cpu.atlas();
  const SurfaceHierarchy& hierarchy = cpu.hierarchy();
  const FlatTriangles& flat = cpu.triangles();
  const size_t n = cpu.elementCount();
  const uint32_t nt = uint32_t(flat.triangles.size());
  const uint32_t ns = uint32_t(cpu.shooterCount());
  s.element_count_ = n;
  s.shooter_count_ = ns;
  s.triangle_count_ = nt;
  s.width_ = atlas.width;
  s.height_ = atlas.height;
  const int d = gl_options.visibility_resolution;

  // ---- Occluders: every scene triangle, tessellated for the depth pass by its size in atlas
  // texels (the longest edge at the atlas's density). ----
  std::vector<GpuProgressiveTriangle> tris(nt);
  std::vector<glm::uvec2> subs;
  glm::dvec3 lo(INFINITY), hi(-INFINITY);
  for (uint32_t t = 0; t < nt; ++t) {
    const glm::uvec3 tri = flat.triangles[t];
    const glm::dvec3 p[3] = {glm::dvec3(flat.positions[tri.x]), glm::dvec3(flat.positions[tri.y]),
                             glm::dvec3(flat.positions[tri.z])};
    GpuProgressiveTriangle& g = tris[t];
    for (int c = 0; c < 3; ++c) {
      g.p0[c] = float(p[0][c]);
      g.p1[c] = float(p[1][c]);
      g.p2[c] = float(p[2][c]);
    }
    const double area = 0.5 * glm::length(glm::cross(p[1] - p[0], p[2] - p[0]));
    g.front_chart = -1;
    g.back_chart = -1;
    const double edge =
        std::max({glm::length(p[1] - p[0]), glm::length(p[2] - p[1]), glm::length(p[0] - p[2])});
    const int k =
        tessellation(int(std::ceil(edge * atlas.texel_density)), gl_options.tessellation_texels);
    g.tessellation = uint32_t(k);
    for (const glm::dvec3& v : p) {
      lo = glm::min(lo, v);
      hi = glm::max(hi, v);
    }
    if (!(area > 0.0)) continue;
    for (int j = 0; j < k; ++j) {
      for (int i = 0; i + j < k; ++i) {
        subs.emplace_back(t, uint32_t(i) | (uint32_t(j) << 8));
        if (i + j < k - 1) subs.emplace_back(t, uint32_t(i) | (uint32_t(j) << 8) | (1u << 16));
      }
    }
  }
  for (size_t f = 0; f < atlas.faces.size(); ++f) {
    const int32_t c = atlas.charts.face_chart[f];
    GpuProgressiveTriangle& g = tris[atlas.faces[f].triangle];
    (atlas.faces[f].back ? g.back_chart : g.front_chart) = c;
  }
  s.far_ = float(1.01 * glm::length(hi - lo) + 1e-6);
  s.sub_triangle_count_ = uint32_t(subs.size());
  // Charts that touch (share a corner position): the depth test's neighbourhood may look past
  // a neighbouring chart across an edge, not past an unconnected occluder (receive.frag).
  std::vector<uint32_t> adjacency_first(atlas.chartCount() + 1, 0), adjacency;
  {
    std::vector<std::pair<glm::vec3, uint32_t>> corners;  // (position, chart)
    for (size_t f = 0; f < atlas.faces.size(); ++f) {
      const int32_t c = atlas.charts.face_chart[f];
      if (c < 0) continue;
      const glm::uvec3 tri = flat.triangles[atlas.faces[f].triangle];
      for (int k = 0; k < 3; ++k) corners.emplace_back(flat.positions[tri[k]], uint32_t(c));
    }
    auto less = [](const std::pair<glm::vec3, uint32_t>& a,
                   const std::pair<glm::vec3, uint32_t>& b) {
      if (a.first.x != b.first.x) return a.first.x < b.first.x;
      if (a.first.y != b.first.y) return a.first.y < b.first.y;
      if (a.first.z != b.first.z) return a.first.z < b.first.z;
      return a.second < b.second;
    };
    std::sort(corners.begin(), corners.end(), less);
    std::vector<std::pair<uint32_t, uint32_t>> pairs;
    for (size_t i = 0; i < corners.size();) {
      size_t j = i;
      while (j < corners.size() && corners[j].first == corners[i].first) ++j;
      for (size_t a = i; a < j; ++a) {
        for (size_t b = a + 1; b < j && b < a + 64; ++b) {
          if (corners[a].second != corners[b].second) {
            pairs.emplace_back(corners[a].second, corners[b].second);
            pairs.emplace_back(corners[b].second, corners[a].second);
          }
        }
      }
      i = j;
    }
    std::sort(pairs.begin(), pairs.end());
    pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
    for (const auto& pr : pairs) ++adjacency_first[pr.first + 1];
    for (size_t c = 0; c < atlas.chartCount(); ++c) adjacency_first[c + 1] += adjacency_first[c];
    for (const auto& pr : pairs) adjacency.push_back(pr.second);
  }

  // ---- Shooters and their points (the CPU's flat substructuring: clusters of one level) ----
  const int level = options.shooter_level;
  std::vector<GpuShooterPoint> points;
  std::vector<GpuShooter> shooters(ns);
  s.point_first_.assign(ns + 1, 0);
  s.point_max_area_.assign(ns, 0.0);
  s.shooter_elements_.resize(ns);
  s.shooter_normal_.resize(ns);
  s.shooter_closed_.resize(ns);
  s.shooter_centre_.resize(ns);
  s.shooter_radius_.resize(ns);
  uint32_t max_points = 0;
  for (uint32_t sh = 0; sh < ns; ++sh) {
    const uint32_t first = cpu.shooterBegin(sh), last = cpu.shooterEnd(sh);
    shooters[sh] = GpuShooter{first, last - first};
    s.shooter_elements_[sh] = glm::uvec2(first, last - first);
    const ClusterRef c = cpu.shooterCluster(sh);
    s.shooter_normal_[sh] = hierarchy.level(c.level).normal[c.index];
    s.shooter_closed_[sh] = cpu.shotClosed(sh) ? 1 : 0;
    glm::dvec3 centre = hierarchy.level(c.level).position[c.index];
    double radius = 0.0;
    for (uint32_t e = first; e < last; ++e) {
      radius = std::max(radius, glm::length(cpu.elementPosition(e) - centre));
    }
    s.shooter_centre_[sh] = centre;
    s.shooter_radius_[sh] = radius;
    s.point_first_[sh] = uint32_t(points.size());
    const std::vector<std::pair<uint32_t, uint32_t>> blocks = cpu.shooterBlocks(sh, level);
    for (const auto& [b0, b1] : blocks) {
      glm::dvec3 position(0.0);
      double area = 0.0;
      for (uint32_t e = b0; e < b1; ++e) {
        position += cpu.elementPosition(e) * cpu.elementArea(e);
        area += cpu.elementArea(e);
      }
      if (!(area > 0.0)) continue;
      // At level 0 a point is its element (its own point, not a mean of one).
      s.point_position_.push_back(b1 - b0 == 1 ? cpu.elementPosition(b0) : position / area);
      s.point_area_.push_back(area);
      s.point_members_.emplace_back(b0, b1 - b0);
      points.push_back(GpuShooterPoint{b0, b1 - b0});
      s.point_max_area_[sh] = std::max(s.point_max_area_[sh], area);
    }
    max_points = std::max(max_points, uint32_t(points.size()) - s.point_first_[sh]);
  }
  s.point_first_[ns] = uint32_t(points.size());
  // Charts: element ranges and bounding spheres, for the near pass.
  const size_t nc = atlas.chartCount();
  s.chart_elements_.resize(nc);
  s.chart_centre_.resize(nc);
  s.chart_radius_.assign(nc, 0.0);
  for (size_t c = 0; c < nc; ++c) {
    const AtlasChartPlacement& pl = atlas.placement[c];
    s.chart_elements_[c] = glm::uvec2(pl.first_element, pl.element_count);
    const ClusterRef root = hierarchy.root(uint32_t(c));
    s.chart_centre_[c] = hierarchy.level(root.level).position[root.index];
    for (uint32_t e = pl.first_element; e < pl.first_element + pl.element_count; ++e) {
      s.chart_radius_[c] =
          std::max(s.chart_radius_[c], glm::length(cpu.elementPosition(e) - s.chart_centre_[c]));
    }
  }

  // ---- Limits, before allocating ----
  GLint max_texture = 0, max_renderbuffer = 0, viewport[2] = {0, 0};
  GLint64 max_ssbo = 0;
  glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_texture);
  glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_renderbuffer);
  glGetIntegerv(GL_MAX_VIEWPORT_DIMS, viewport);
  glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &max_ssbo);
  int max_size = std::min({max_texture, max_renderbuffer, viewport[0], viewport[1]});
  if (gl_options.max_texture_size > 0) max_size = std::min(max_size, gl_options.max_texture_size);
  const uint64_t texels = uint64_t(atlas.width) * uint64_t(atlas.height);
  // Radiosity, residual, incident and two radiance atlases (RGBA32F).
  const uint64_t atlas_bytes = texels * (5 * 16);
  // A batch of tiles x tiles shooter points shares one depth texture (kMaxTiles^2 points per
  // receiver pass), as many tiles as the texture size allows.
  s.tiles_ = uint32_t(std::clamp(max_size / std::max(d, 1), 1, kMaxTiles));
  const uint64_t depth_side = uint64_t(d) * s.tiles_;
  const uint64_t depth_bytes = depth_side * depth_side * 8;  // depth and triangle id
  const uint64_t groups = ceilDiv(std::max<size_t>(n, 1), kResolveGroup);
  // Element pieces (for the near pairs' exact form factor), 8 corners each.
  uint64_t piece_count = 0;
  for (size_t e = 0; e < n; ++e) {
    piece_count += atlas.element_face_first[e + 1] - atlas.element_face_first[e];
  }
  const struct {
    const char* what;
    uint64_t bytes;
  } buffers[] = {
      {"texel-to-element map", texels * 4},
      {"texel-to-chart map", texels * 4},
      {"element", uint64_t(n) * sizeof(GpuProgressiveElement)},
      {"element area", uint64_t(n) * 8},
      {"element position", uint64_t(n) * 24},
      {"element piece", piece_count * 8 * 16},
      {"triangle", uint64_t(nt) * sizeof(GpuProgressiveTriangle)},
      {"shooter", uint64_t(ns) * sizeof(GpuShooter)},
      {"shooter point", uint64_t(points.size()) * sizeof(GpuShooterPoint)},
      {"shooter point power", uint64_t(points.size()) * 32},
      {"sub-triangle", uint64_t(subs.size()) * 8},
      {"shooter power", uint64_t(ns) * 32},
      {"resolve sums", groups * sizeof(GpuResolveSums)},
      // Coarse receivers (at most one per element) and the samples of subdivision.
      {"receiver", uint64_t(n) * (sizeof(GpuProgressiveElement) + 24)},
      {"subdivision sample", uint64_t(n) * 4},
  };
  uint64_t buffer_bytes = sizeof(GpuBatchPoint) * 16;
  for (const auto& b : buffers) buffer_bytes += b.bytes;
  const uint64_t total = atlas_bytes + depth_bytes + buffer_bytes;
  s.device_bytes_ = total;
  if (atlas.width > max_size || atlas.height > max_size) {
    return inputError(
        "", place,
        fmt::format("the {}x{} lightmap atlas needs {} bytes ({}) of textures, but this "
                    "device's maximum texture size (and render target size) is {}; lower the "
                    "texel density or use the CPU",
                    atlas.width, atlas.height, atlas_bytes, formatBytes(atlas_bytes), max_size));
  }
  if (d > max_size) {
    return inputError(
        "", place,
        fmt::format("the {}x{} visibility depth map needs {} bytes ({}), but this device's "
                    "maximum texture size is {}; lower the visibility resolution",
                    d, d, uint64_t(d) * uint64_t(d) * 4, formatBytes(uint64_t(d) * uint64_t(d) * 4),
                    max_size));
  }
  for (const auto& b : buffers) {
    if (b.bytes > uint64_t(max_ssbo)) {
      return inputError(
          "", place,
          fmt::format("the {} buffer needs {} bytes ({}), but this device allows {} "
                      "per shader storage block (GL_MAX_SHADER_STORAGE_BLOCK_SIZE)",
                      b.what, b.bytes, formatBytes(b.bytes), formatBytes(uint64_t(max_ssbo))));
    }
  }
  if (ceilDiv(max_points, kPointGroup) > kMaxGroups || uint64_t(subs.size()) * 6 > INT32_MAX ||
      n > uint64_t(INT32_MAX)) {
    return inputError("", place,
                      fmt::format("{} elements in {} triangles exceed the dispatch limits", n, nt));
  }
  if (softwareRenderer()) {
    PENUMBRA_TRY(checkMemory(total, "progressive radiosity on a software OpenGL device"));
  } else if (epoxy_has_gl_extension("GL_NVX_gpu_memory_info")) {
    GLint free_kib = 0;
    glGetIntegerv(GL_GPU_MEMORY_INFO_CURRENT_AVAILABLE_VIDMEM_NVX, &free_kib);
    if (free_kib > 0 && total > uint64_t(free_kib) * 1024) {
      return inputError(
          "", place,
          fmt::format("needs {} bytes ({}) of device memory; the device has {} free", total,
                      formatBytes(total), formatBytes(uint64_t(free_kib) * 1024)));
    }
  }

  // ---- Programs ----
  const char* pass_names[6] = {"power", "select", "points", "resolve", "radiance", "fill"};
  gl::Program* passes[6] = {&s.power_, &s.select_, &s.points_, &s.resolve_, &s.radiance_, &s.fill_};
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
  {
    Expected<gl::Program> p =
        gl::renderProgram("radiosity/progressive_depth.vert", "radiosity/progressive_depth.frag");
    if (!p) return p.error();
    s.depth_ = std::move(*p);
    for (int near = 0; near < 2; ++near) {
      p = gl::renderProgram(
          "radiosity/progressive_receive.vert", "radiosity/progressive_receive.frag",
          {fmt::format("NEAR_PASS {}", near),
           fmt::format("VISIBILITY {}", options.visibility ? 1 : 0), "SAMPLE_PASS 0"});
      if (!p) return p.error();
      (near ? s.receive_near_ : s.receive_far_) = std::move(*p);
    }
    if (options.adaptive) {
      p = gl::renderProgram(
          "radiosity/progressive_receive.vert", "radiosity/progressive_receive.frag",
          {"NEAR_PASS 0", fmt::format("VISIBILITY {}", options.visibility ? 1 : 0),
           "SAMPLE_PASS 1"});
      if (!p) return p.error();
      s.sample_ = std::move(*p);
    }
  }

  // ---- Per-element and per-texel data, from the CPU solver (identical elements) ----
  std::vector<GpuProgressiveElement> elements(n);
  std::vector<double> element_area(n);
  std::vector<int32_t> texel_element(texels, -1);
  std::vector<glm::vec4> polygons;  // 8 corners per piece
  polygons.reserve(size_t(piece_count) * 8);
  s.element_texel_.resize(n);
  glm::dvec3 rho_area(0.0);
  std::vector<std::array<glm::dvec3, 8>> pieces;
  std::vector<int> counts;
  for (size_t e = 0; e < n; ++e) {
    const uint32_t texel = cpu.elementTexel(e);
    GpuProgressiveElement& g = elements[e];
    const glm::dvec3 pos = cpu.elementPosition(e);
    for (int c = 0; c < 3; ++c) {
      g.position[c] = float(pos[c]);
      g.reflectance[c] = float(cpu.reflectance(e)[c]);
      g.normal[c] = float(cpu.elementNormal(e)[c]);
      g.shading_normal[c] = float(cpu.surface().shading_normal[e][c]);
    }
    g.area = float(cpu.elementArea(e));
    g.texel = texel;
    // The element's point lies on its face's triangle (chart_atlas.h); its barycentrics there
    // take the back projection through the sub-triangle the depth pass rasterised.
    g.triangle = atlas.faces[atlas.element_face[e]].triangle;
    g.barycentric[0] = atlas.element_barycentric[e].x;
    g.barycentric[1] = atlas.element_barycentric[e].y;
    // Its pieces in world space, padded to 8 corners by repeating the last.
    cpu.elementPieces(e, pieces, counts);
    g.piece_first = uint32_t(polygons.size() / 8);
    g.piece_count = 0;
    for (size_t q = 0; q < pieces.size(); ++q) {
      if (counts[q] < 3) continue;
      for (int k = 0; k < 8; ++k) {
        polygons.emplace_back(glm::vec3(pieces[q][size_t(std::min(k, counts[q] - 1))]), 0.0f);
      }
      ++g.piece_count;
    }
    element_area[e] = cpu.elementArea(e);
    texel_element[texel] = int32_t(e);
    s.element_texel_[e] = texel;
    s.total_area_ += cpu.elementArea(e);
    rho_area += cpu.reflectance(e) * cpu.elementArea(e);
  }
  s.ambient_factor_ =
      s.total_area_ > 0.0 ? 1.0 / (1.0 - rho_area / s.total_area_) : glm::dvec3(1.0);

  // ---- Buffers ----
  s.triangles_ = makeBuffer(tris);
  s.shooters_ = makeBuffer(shooters);
  s.elements_ = makeBuffer(elements);
  s.element_area_ = makeBuffer(element_area);
  s.texel_element_ = makeBuffer(texel_element);
  s.texel_chart_ = makeBuffer(atlas.texel_chart);
  s.points_buf_ = makeBuffer(points);
  s.sub_triangles_ = makeBuffer(subs);
  s.polygons_ = makeBuffer(polygons);
  s.chart_adjacency_first_ = makeBuffer(adjacency_first);
  s.chart_adjacency_ = makeBuffer(adjacency);
  {
    std::vector<double> ep(3 * n);
    for (size_t e = 0; e < n; ++e) {
      for (int c = 0; c < 3; ++c) ep[3 * e + size_t(c)] = cpu.elementPosition(e)[c];
    }
    s.element_position_d_ = makeBuffer(ep);
  }
  s.point_power_ = gl::Buffer(std::max<size_t>(points.size(), 1) * 32, nullptr, 0);
  s.batch_ = gl::Buffer(sizeof(GpuBatchPoint) * kMaxTiles * kMaxTiles, nullptr);
  s.shooter_power_ = gl::Buffer(std::max<size_t>(ns, 1) * 32, nullptr, 0);
  s.selection_ = gl::Buffer(sizeof(GpuSelection), nullptr, 0);
  s.sums_ = gl::Buffer(size_t(groups) * sizeof(GpuResolveSums), nullptr, 0);
  s.samples_ = gl::Buffer(std::max<size_t>(n, 1) * 4, nullptr, GL_DYNAMIC_STORAGE_BIT);
  s.surface_ = &cpu.surface();
  s.receivers_ = cpu.receivers();

  // ---- Textures and framebuffers ----
  s.radiosity_ = makeTexture(GL_RGBA32F, atlas.width, atlas.height);
  s.residual_ = makeTexture(GL_RGBA32F, atlas.width, atlas.height);
  s.incident_ = makeTexture(GL_RGBA32F, atlas.width, atlas.height);
  for (gl::Texture& t : s.radiance_maps_) t = makeTexture(GL_RGBA32F, atlas.width, atlas.height);
  s.depth_map_ = makeTexture(GL_DEPTH_COMPONENT32F, d * int(s.tiles_), d * int(s.tiles_));
  glTextureParameteri(s.depth_map_.id(), GL_TEXTURE_COMPARE_MODE, GL_NONE);
  s.id_map_ = makeTexture(GL_R32UI, d * int(s.tiles_), d * int(s.tiles_));
  s.atlas_fbo_ = gl::createFramebuffer();
  glNamedFramebufferTexture(s.atlas_fbo_.id(), GL_COLOR_ATTACHMENT0, s.incident_.id(), 0);
  glNamedFramebufferDrawBuffer(s.atlas_fbo_.id(), GL_COLOR_ATTACHMENT0);
  s.depth_fbo_ = gl::createFramebuffer();
  glNamedFramebufferTexture(s.depth_fbo_.id(), GL_DEPTH_ATTACHMENT, s.depth_map_.id(), 0);
  glNamedFramebufferTexture(s.depth_fbo_.id(), GL_COLOR_ATTACHMENT0, s.id_map_.id(), 0);
  glNamedFramebufferDrawBuffer(s.depth_fbo_.id(), GL_COLOR_ATTACHMENT0);
  glNamedFramebufferReadBuffer(s.depth_fbo_.id(), GL_NONE);
  for (GLuint fbo : {s.atlas_fbo_.id(), s.depth_fbo_.id()}) {
    if (glCheckNamedFramebufferStatus(fbo, GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
      return runtimeError("", "progressive radiosity: a framebuffer is incomplete on this device");
    }
  }
  s.vao_ = gl::createVertexArray();

  const GLenum err = glGetError();
  if (err == GL_OUT_OF_MEMORY) {
    return runtimeError("", fmt::format("progressive radiosity on the GPU: out of device memory "
                                        "for {} of textures and buffers",
                                        formatBytes(total)));
  }
  if (err != GL_NO_ERROR) {
    return runtimeError(
        "",
        fmt::format("OpenGL error 0x{:x} while uploading the progressive radiosity atlas", err));
  }
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
    b[element_texel_[e]] = glm::vec4(glm::vec3(be), 1.0f);
    db[element_texel_[e]] = glm::vec4(glm::vec3(dbe), 1.0f);
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
  readTexture(radiosity_.id(), width_, height_, b);
  readTexture(residual_.id(), width_, height_, db);
  PENUMBRA_TRY(glStatus("reading back the progressive radiosity state"));
  ProgressiveState st;
  st.radiosity.resize(element_count_);
  st.residual.resize(element_count_);
  for (size_t e = 0; e < element_count_; ++e) {
    st.radiosity[e] = glm::dvec3(glm::vec3(b[element_texel_[e]]));
    st.residual[e] = glm::dvec3(glm::vec3(db[element_texel_[e]]));
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
  elements_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_ELEMENTS);
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
  const size_t nc = chart_elements_.size();
  chart_receivers_.assign(nc, glm::uvec2(0));
  if (receivers_.perElement()) {
    chart_receivers_ = chart_elements_;
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
    g.texel = element_texel_[receivers_.texelElement(k)];
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
  receivers_buf_ = makeBuffer(r);
  receiver_position_d_ = makeBuffer(position);
}

Status GlProgressive::spreadIncident() {
  if (receivers_.perElement()) return {};
  std::vector<glm::vec4> rgba;
  glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT);
  readTexture(incident_.id(), width_, height_, rgba);
  std::vector<glm::dvec3> gathered(receivers_.size());
  for (size_t k = 0; k < receivers_.size(); ++k) {
    gathered[k] = glm::dvec3(glm::vec3(rgba[element_texel_[receivers_.texelElement(k)]]));
  }
  const std::vector<glm::dvec3> spread = receivers_.toElements(*surface_, std::move(gathered));
  std::fill(rgba.begin(), rgba.end(), glm::vec4(0.0f));
  for (size_t e = 0; e < element_count_; ++e) {
    rgba[element_texel_[e]] = glm::vec4(glm::vec3(spread[e]), 0.0f);
  }
  glTextureSubImage2D(incident_.id(), 0, 0, 0, width_, height_, GL_RGBA, GL_FLOAT, rgba.data());
  return glStatus("interpolating the receivers' irradiance");
}

void GlProgressive::drawReceivers(const gl::Program& program, uint32_t first, uint32_t count,
                                  bool elements) {
  if (count == 0) return;
  glBindFramebuffer(GL_FRAMEBUFFER, atlas_fbo_.id());
  glViewport(0, 0, width_, height_);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  glDisable(GL_MULTISAMPLE);
  glDisable(GL_STENCIL_TEST);
  glEnable(GL_BLEND);
  glBlendEquation(GL_FUNC_ADD);
  glBlendFunc(GL_ONE, GL_ONE);
  glUseProgram(program.id());
  glProgramUniform1i(program.id(), uniform(program, "atlas_width"), width_);
  glProgramUniform1i(program.id(), uniform(program, "atlas_height"), height_);
  elements_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_ELEMENTS);
  triangles_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_TRIANGLES);
  const bool own = elements || receivers_.perElement();
  (own ? elements_ : receivers_buf_).bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_RECEIVERS);
  (own ? element_position_d_ : receiver_position_d_)
      .bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_ELEMENT_POSITION_D);
  samples_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_SAMPLES);
  polygons_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_POLYGONS);
  batch_.bindBase(GL_UNIFORM_BUFFER, PROGRESSIVE_UBO_BATCH);
  glBindTextureUnit(PROGRESSIVE_TEXTURE_DEPTH_MAP, depth_map_.id());
  glBindTextureUnit(PROGRESSIVE_TEXTURE_RESIDUAL_MAP, residual_.id());
  glBindTextureUnit(PROGRESSIVE_TEXTURE_ID_MAP, id_map_.id());
  texel_chart_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_TEXEL_CHART);
  chart_adjacency_first_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_ADJACENCY_FIRST);
  chart_adjacency_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_ADJACENCY);
  glBindVertexArray(vao_.id());
  // One point of size 1 at each element's texel centre: exactly one fragment per element (the
  // paper rasterises the receiver triangles through their lightmap UVs; every fragment of a
  // texel computes the same value from its element's data, so one per texel is what counts).
  glDisable(GL_PROGRAM_POINT_SIZE);
  glPointSize(1.0f);
  glDrawArrays(GL_POINTS, GLint(first), GLsizei(count));
  glBindVertexArray(0);
  glDisable(GL_BLEND);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
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
  elements_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_ELEMENTS);
  sums_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_SUMS);
  element_area_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_ELEMENT_AREA);
  glBindImageTexture(PROGRESSIVE_IMAGE_RESIDUAL, residual_.id(), 0, GL_FALSE, 0, GL_READ_WRITE,
                     GL_RGBA32F);
  glBindImageTexture(PROGRESSIVE_IMAGE_RADIOSITY, radiosity_.id(), 0, GL_FALSE, 0, GL_READ_WRITE,
                     GL_RGBA32F);
  glBindTextureUnit(PROGRESSIVE_TEXTURE_INCIDENT_MAP, incident_.id());
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

void GlProgressive::prepareBatch(const std::vector<uint32_t>& active,
                                 const std::vector<glm::dvec3>& active_residual,
                                 uint32_t point_first, uint32_t first, uint32_t count) {
  // The batch's points, as uniforms of the passes.
  std::array<GpuBatchPoint, kMaxTiles * kMaxTiles> points{};
  for (uint32_t k = 0; k < count; ++k) {
    const uint32_t p = active[first + k];
    GpuBatchPoint& b = points[k];
    for (int c = 0; c < 3; ++c) {
      b.position[c] = point_position_[p][c];
      b.position_f[c] = float(point_position_[p][c]);
      b.residual[c] = float(active_residual[first + k][c]);
    }
    b.position[3] = point_area_[p];
    b.position_f[3] = float(point_area_[p]);
    b.members[0] = point_members_[p].x;
    b.members[1] = point_members_[p].y;
    b.members[2] = p - point_first;
  }
  batch_.upload(points.data(), count * sizeof(GpuBatchPoint));
  batch_.bindBase(GL_UNIFORM_BUFFER, PROGRESSIVE_UBO_BATCH);
  if (!options_.visibility) return;
  // Algorithm 1: the scene's depth from each point of the batch, hemispherical projection, one
  // instance (and one tile of the depth texture) per point.
  const GLint d = gl_options_.visibility_resolution * GLint(tiles_);
  glBindFramebuffer(GL_FRAMEBUFFER, depth_fbo_.id());
  glViewport(0, 0, d, d);
  glDisable(GL_BLEND);
  glDisable(GL_STENCIL_TEST);
  glDisable(GL_CULL_FACE);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_TRUE);
  for (int c = 0; c < 4; ++c) glEnable(GLenum(GL_CLIP_DISTANCE0 + c));
  const GLfloat far_depth = 1.0f;
  glClearNamedFramebufferfv(depth_fbo_.id(), GL_DEPTH, 0, &far_depth);
  const GLuint no_triangle[4] = {0xffffffffu, 0u, 0u, 0u};
  glClearNamedFramebufferuiv(depth_fbo_.id(), GL_COLOR, 0, no_triangle);
  glUseProgram(depth_.id());
  triangles_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_TRIANGLES);
  sub_triangles_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_SUB_TRIANGLES);
  glBindVertexArray(vao_.id());
  glDrawArraysInstanced(GL_TRIANGLES, 0, GLsizei(6 * sub_triangle_count_), GLsizei(count));
  glBindVertexArray(0);
  for (int c = 0; c < 4; ++c) glDisable(GLenum(GL_CLIP_DISTANCE0 + c));
  glDisable(GL_DEPTH_TEST);
}

Status GlProgressive::subdivide(uint32_t shooter, const std::vector<uint32_t>& active,
                                const std::vector<glm::dvec3>& active_residual,
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
  glProgramUniform1ui(sample_.id(), uniform(sample_, "sample_points"), point_count);
  const uint32_t batch = tiles_ * tiles_;
  for (uint32_t first = 0; first < uint32_t(active.size()); first += batch) {
    const uint32_t count = std::min(batch, uint32_t(active.size()) - first);
    prepareBatch(active, active_residual, point_first, first, count);
    glProgramUniform1ui(sample_.id(), uniform(sample_, "batch_count"), count);
    drawReceivers(sample_, 0, uint32_t(n), /*elements=*/true);
  }
  glUseProgram(0);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT);
  std::vector<uint32_t> bits(n);
  if (n > 0) samples_.download(bits.data(), n * 4);
  std::vector<glm::vec4> b;
  readTexture(radiosity_.id(), width_, height_, b);
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
    share[e] = float(subdivisionShare(irradiance, glm::dvec3(glm::vec3(b[element_texel_[e]])),
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

  // Shooter points: dB sums per cluster (substructuring, sec. 3).
  std::vector<glm::dvec4> point_power(point_count);
  if (point_count > 0) {
    glUseProgram(points_.id());
    glUniform1ui(uniform(points_, "point_first"), point_first);
    glUniform1ui(uniform(points_, "point_count"), point_count);
    glUniform1i(uniform(points_, "atlas_width"), width_);
    elements_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_ELEMENTS);
    points_buf_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_POINTS);
    point_power_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_POINT_POWER);
    element_area_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_ELEMENT_AREA);
    glBindImageTexture(PROGRESSIVE_IMAGE_RESIDUAL, residual_.id(), 0, GL_FALSE, 0, GL_READ_ONLY,
                       GL_RGBA32F);
    glDispatchCompute(ceilDiv(point_count, kPointGroup), 1, 1);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
    glUseProgram(0);
    point_power_.download(point_power.data(), point_count * 32, size_t(point_first) * 32);
  }
  glm::dvec3 shot(0.0);
  std::vector<uint32_t> active;             // points with something to shoot (the CPU drops dB = 0)
  std::vector<glm::dvec3> active_residual;  // their area-weighted mean dB
  for (uint32_t k = 0; k < point_count; ++k) {
    const glm::dvec3 p(point_power[k]);
    shot += p;
    if (p != glm::dvec3(0.0)) {
      active.push_back(point_first + k);
      active_residual.push_back(p / point_area_[point_first + k]);
    }
  }
  it.shooter_points = uint32_t(active.size());

  if (!active.empty()) {
    const glm::dvec3 ns = shooter_normal_[shooter];
    setHemisphere(depth_, ns, far_);
    glProgramUniform1ui(depth_.id(), uniform(depth_, "tiles"), tiles_);
    for (const gl::Program* r : {&receive_far_, &receive_near_, &sample_}) {
      if (r->id() == 0) continue;
      const GLuint rid = r->id();
      setHemisphere(*r, ns, far_);
      glProgramUniform1ui(rid, uniform(*r, "tiles"), tiles_);
      if (options_.visibility) {
        glProgramUniform1f(rid, uniform(*r, "depth_tolerance"), gl_options_.depth_tolerance);
      }
      if (r == &sample_) continue;  // the samples pass has no pairs
      glProgramUniform1f(rid, uniform(*r, "near_factor"), float(kProgressiveNear));
      glProgramUniform1i(rid, uniform(*r, "count_mode"), 0);
    }
  }
  // Sec. 4 before the shooter's first shot: receivers split at its shadow boundaries, so that
  // the shot below gathers at the new ones.
  if (options_.adaptive && !subdivided_[shooter]) {
    PENUMBRA_TRY(subdivide(shooter, active, active_residual, shot, it));
  }

  const GLfloat zero4[4] = {0.0f, 0.0f, 0.0f, 0.0f};
  glClearTexImage(incident_.id(), 0, GL_RGBA, GL_FLOAT, zero4);
  // Near pairs need d^2 < kNear^2 A for some point of the shooter: charts whose bounding
  // spheres are farther from the shooter's than that cannot have one.
  std::vector<glm::uvec2> near_charts;
  const double reach = kProgressiveNear * std::sqrt(point_max_area_[shooter]);
  for (size_t c = 0; c < chart_elements_.size(); ++c) {
    const double gap = glm::length(chart_centre_[c] - shooter_centre_[shooter]) - chart_radius_[c] -
                       shooter_radius_[shooter];
    if (gap < reach * (1.0 + 1e-6) && chart_receivers_[c].y > 0) {
      near_charts.push_back(chart_receivers_[c]);
    }
  }
  if (!active.empty()) {
    const uint32_t batch = tiles_ * tiles_;
    for (uint32_t first = 0; first < uint32_t(active.size()); first += batch) {
      const uint32_t count = std::min(batch, uint32_t(active.size()) - first);
      prepareBatch(active, active_residual, point_first, first, count);
      // Far pairs over every receiver, near pairs over the charts that can have them.
      for (const gl::Program* r : {&receive_far_, &receive_near_}) {
        glProgramUniform1ui(r->id(), uniform(*r, "batch_count"), count);
      }
      drawReceivers(receive_far_, 0, uint32_t(receivers_.size()));
      for (const glm::uvec2& c : near_charts) drawReceivers(receive_near_, c.x, c.y);
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
  elements_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_ELEMENTS);
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
  texel_chart_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_TEXEL_CHART);
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
  readTexture(radiance_maps_[size_t(current)].id(), width_, height_, rgba);
  PENUMBRA_TRY(glStatus("computing the radiance atlas"));
  Image img(width_, height_);
  for (size_t i = 0; i < texels; ++i) img.pixels[i] = glm::vec3(rgba[i]);
  return img;
}

Expected<std::vector<uint32_t>> GlProgressive::receiverCoverage() {
  const GLfloat zero4[4] = {0.0f, 0.0f, 0.0f, 0.0f};
  glClearTexImage(incident_.id(), 0, GL_RGBA, GL_FLOAT, zero4);
  const gl::Program& r = receive_far_;
  glProgramUniform1i(r.id(), uniform(r, "count_mode"), 1);
  drawReceivers(r, 0, uint32_t(element_count_), /*elements=*/true);
  glProgramUniform1i(r.id(), uniform(r, "count_mode"), 0);
  glUseProgram(0);
  std::vector<glm::vec4> rgba;
  glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT);
  readTexture(incident_.id(), width_, height_, rgba);
  glClearTexImage(incident_.id(), 0, GL_RGBA, GL_FLOAT, zero4);
  PENUMBRA_TRY(glStatus("rendering the receiver coverage"));
  std::vector<uint32_t> out(element_count_);
  for (size_t e = 0; e < element_count_; ++e) {
    out[e] = uint32_t(std::lround(rgba[element_texel_[e]].x));
  }
  return out;
}

}  // namespace penumbra
