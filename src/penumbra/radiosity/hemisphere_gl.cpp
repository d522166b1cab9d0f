#include "penumbra/radiosity/hemisphere_gl.h"
#include "penumbra/radiosity/cutout_jitter.h"
#include "radiosity/progressive_bindings.glsl"

#include "penumbra/core/memory.h"
#include "penumbra/gpu/program.h"
#include "penumbra/gpu/storage.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <glm/vec4.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

namespace penumbra {

namespace {

constexpr int kMaxTessellation = 64;  // sub-triangle grid per triangle (code: 8 bits each)
// Points closer to the shooter's plane than this fraction of the far plane count as on it (the
// float rounding of coplanar geometry; the CPU lifts its shadow rays by 1e-5 of the scene too).
constexpr float kOnPlane = 1e-5f;
constexpr int kMaxTiles = kProgressiveBatchTiles;

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

// The depth pass's sub-triangle grid of a triangle `leg` atlas texels across: k x k
// sub-triangles with legs of about `texels` texels.
int tessellation(int leg, int texels) {
  return std::clamp((leg + texels - 1) / texels, 1, kMaxTessellation);
}

// Charts that touch (share a corner position): the depth test's neighbourhood may look past a
// neighbouring chart across an edge, not past an unconnected occluder (receive.frag). As CSR:
// chart c's neighbours are adjacency[first[c] .. first[c + 1]).
void chartAdjacency(const ChartAtlas& atlas, const FlatTriangles& flat,
                    std::vector<uint32_t>& first, std::vector<uint32_t>& adjacency) {
  first.assign(atlas.chartCount() + 1, 0);
  adjacency.clear();
  std::vector<std::pair<glm::vec3, uint32_t>> corners;  // (position, chart)
  for (size_t f = 0; f < atlas.faces.size(); ++f) {
    const int32_t c = atlas.charts.face_chart[f];
    if (c < 0) continue;
    const glm::uvec3 tri = flat.triangles[atlas.faces[f].triangle];
    for (int k = 0; k < 3; ++k) corners.emplace_back(flat.positions[tri[k]], uint32_t(c));
  }
  auto less = [](const std::pair<glm::vec3, uint32_t>& a, const std::pair<glm::vec3, uint32_t>& b) {
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
  for (const auto& pr : pairs) ++first[pr.first + 1];
  for (size_t c = 0; c < atlas.chartCount(); ++c) first[c + 1] += first[c];
  for (const auto& pr : pairs) adjacency.push_back(pr.second);
}

// The options create() takes from GlProgressiveOptions, checked.
Status checkGatherOptions(const GlProgressiveOptions& gl_options, const char* place) {
  if (gl_options.visibility_resolution < 16) {
    return inputError("", place, "the visibility resolution must be at least 16 texels");
  }
  if (gl_options.tessellation_texels < 1) {
    return inputError("", place, "tessellation_texels must be at least 1");
  }
  if (gl_options.gap_fill_passes < 0 || !(gl_options.depth_tolerance >= 0.0f)) {
    return inputError("", place, "gap_fill_passes and depth_tolerance must not be negative");
  }
  return {};
}

// The depth pass's occluders: every scene triangle with the charts of its faces, its
// sub-triangles (triangle, code), and the far plane (a little beyond the scene's diagonal).
struct Occluders {
  std::vector<GpuProgressiveTriangle> triangles;
  std::vector<glm::uvec2> subs;
  float far = 1.0f;
};

// Every scene triangle, tessellated for the depth pass by its size in atlas texels (the longest
// edge at the atlas's density).
Occluders buildOccluders(const ChartAtlas& atlas, const FlatTriangles& flat,
                         int tessellation_texels) {
  const uint32_t nt = uint32_t(flat.triangles.size());
  Occluders o;
  std::vector<GpuProgressiveTriangle>& tris = o.triangles;
  std::vector<glm::uvec2>& subs = o.subs;
  tris.resize(nt);
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
    const int k = tessellation(int(std::ceil(edge * atlas.texel_density)), tessellation_texels);
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
  o.far = float(1.01 * glm::length(hi - lo) + 1e-6);
  return o;
}

// The device's largest texture, render target and viewport side (at most the option's), and
// its largest shader storage block.
void deviceLimits(const GlProgressiveOptions& gl_options, int& max_size, GLint64& max_ssbo) {
  GLint max_texture = 0, max_renderbuffer = 0, viewport[2] = {0, 0};
  max_ssbo = 0;
  glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_texture);
  glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_renderbuffer);
  glGetIntegerv(GL_MAX_VIEWPORT_DIMS, viewport);
  glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &max_ssbo);
  max_size = std::min({max_texture, max_renderbuffer, viewport[0], viewport[1]});
  if (gl_options.max_texture_size > 0) max_size = std::min(max_size, gl_options.max_texture_size);
}

// Element pieces (for the near pairs' exact form factor), 8 corners each.
uint64_t elementPieceCount(const ChartAtlas& atlas) {
  uint64_t piece_count = 0;
  for (size_t e = 0; e < atlas.elementCount(); ++e) {
    piece_count += atlas.element_face_first[e + 1] - atlas.element_face_first[e];
  }
  return piece_count;
}

// The buffers the gather allocates for n elements, nt triangles and their sub-triangles, then
// the caller's.
std::vector<GlBufferNeed> bufferNeeds(size_t n, uint64_t texels, uint64_t piece_count, uint32_t nt,
                                      size_t sub_triangles, size_t adjacency_words,
                                      std::span<const GlBufferNeed> caller_buffers) {
  std::vector<GlBufferNeed> buffers = {
      {"texel-to-chart map", texels * 4},
      {"element", uint64_t(n) * sizeof(GpuProgressiveElement)},
      {"element position", uint64_t(n) * 24},
      {"element piece", piece_count * 8 * 16},
      {"triangle", uint64_t(nt) * sizeof(GpuProgressiveTriangle)},
      {"sub-triangle", uint64_t(sub_triangles) * 8},
      {"chart adjacency", uint64_t(adjacency_words) * 4},
  };
  buffers.insert(buffers.end(), caller_buffers.begin(), caller_buffers.end());
  return buffers;
}

// The atlas, the depth maps, every buffer and the dispatches within the device's limits.
Status checkLimits(const ChartAtlas& atlas, int d, int max_size, GLint64 max_ssbo,
                   uint64_t atlas_bytes, const std::vector<GlBufferNeed>& buffers,
                   size_t sub_triangles, size_t n, uint32_t nt, const char* place) {
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
  for (const GlBufferNeed& b : buffers) {
    if (b.bytes > uint64_t(max_ssbo)) {
      return inputError(
          "", place,
          fmt::format("the {} buffer needs {} bytes ({}), but this device allows {} "
                      "per shader storage block (GL_MAX_SHADER_STORAGE_BLOCK_SIZE)",
                      b.what, b.bytes, formatBytes(b.bytes), formatBytes(uint64_t(max_ssbo))));
    }
  }
  if (uint64_t(sub_triangles) * 6 > INT32_MAX || n > uint64_t(INT32_MAX)) {
    return inputError("", place,
                      fmt::format("{} elements in {} triangles exceed the dispatch limits", n, nt));
  }
  return {};
}

// The whole (`total` bytes) within the machine's memory on a software rasteriser, or within the
// free video memory where the driver says.
Status checkDeviceMemory(uint64_t total, const char* place) {
  if (gl::softwareRenderer()) {
    PENUMBRA_TRY(checkMemory(total, fmt::format("{} on a software OpenGL device", place)));
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
  return {};
}

}  // namespace

std::vector<std::string> batchPointDefines() {
  return {fmt::format("MAX_BATCH_POINTS {}", kMaxTiles * kMaxTiles)};
}

namespace {

// The depth pass, the far and near receiver passes and (with `samples`) the samples pass.
Status compilePrograms(bool visibility, bool samples, bool cutouts, gl::Program& depth,
                       gl::Program& receive_far, gl::Program& receive_near, gl::Program& sample) {
  std::vector<std::string> depth_defines = batchPointDefines();
  if (cutouts) depth_defines.push_back(cutoutDefine(PROGRESSIVE_SSBO_CUTOUTS));
  Expected<gl::Program> p = gl::renderProgram("radiosity/progressive_depth.vert",
                                              "radiosity/progressive_depth.frag", depth_defines);
  if (!p) return p.error();
  depth = std::move(*p);
  const auto receiveDefines = [&](int near, int sample_pass) {
    std::vector<std::string> d = {
        fmt::format("NEAR_PASS {}", near), fmt::format("VISIBILITY {}", visibility ? 1 : 0),
        fmt::format("SAMPLE_PASS {}", sample_pass), batchPointDefines()[0]};
    if (cutouts) d.push_back(cutoutDefine(PROGRESSIVE_SSBO_CUTOUTS));
    return d;
  };
  for (int near = 0; near < 2; ++near) {
    p = gl::renderProgram("radiosity/progressive_receive.vert",
                          "radiosity/progressive_receive.frag", receiveDefines(near, 0));
    if (!p) return p.error();
    (near ? receive_near : receive_far) = std::move(*p);
  }
  if (samples) {
    p = gl::renderProgram("radiosity/progressive_receive.vert",
                          "radiosity/progressive_receive.frag", receiveDefines(0, 1));
    if (!p) return p.error();
    sample = std::move(*p);
  }
  return {};
}

// The elements as the GPU reads them: GpuProgressiveElement, their points in double and their
// pieces (8 corners each).
struct ElementData {
  std::vector<GpuProgressiveElement> elements;
  std::vector<glm::vec4> polygons;
  std::vector<double> position_d;
};

// The CPU's elements: exact-coverage points, normals, areas, reflectances and pieces
// (`piece_count` of them at most), and each one's texel in `element_texel`.
ElementData elementData(const RadiositySurface& surface, uint64_t piece_count,
                        std::vector<uint32_t>& element_texel) {
  const ChartAtlas& atlas = surface.atlas;
  const FlatTriangles& flat = surface.flat;
  const size_t n = surface.elementCount();
  ElementData data;
  std::vector<GpuProgressiveElement>& elements = data.elements;
  std::vector<glm::vec4>& polygons = data.polygons;  // 8 corners per piece
  elements.resize(n);
  polygons.reserve(size_t(piece_count) * 8);
  data.position_d.resize(3 * n);
  element_texel.resize(n);
  std::vector<std::array<glm::dvec3, 8>> pieces;
  std::vector<int> counts;
  for (size_t e = 0; e < n; ++e) {
    GpuProgressiveElement& g = elements[e];
    const glm::dvec3 pos = atlas.element_position[e];
    for (int c = 0; c < 3; ++c) {
      g.position[c] = float(pos[c]);
      data.position_d[3 * e + size_t(c)] = pos[c];
      g.reflectance[c] = float(surface.reflectance[e][c]);
      g.normal[c] = float(atlas.element_normal[e][c]);
      g.shading_normal[c] = float(surface.shading_normal[e][c]);
    }
    g.area = float(atlas.element_area[e]);
    g.texel = atlas.element_texel[e];
    // The element's point lies on its face's triangle (chart_atlas.h); its barycentrics there
    // take the back projection through the sub-triangle the depth pass rasterised.
    g.triangle = atlas.faces[atlas.element_face[e]].triangle;
    g.barycentric[0] = atlas.element_barycentric[e].x;
    g.barycentric[1] = atlas.element_barycentric[e].y;
    // Its pieces in world space, padded to 8 corners by repeating the last.
    atlas.elementPieces(e, flat.positions, flat.triangles, pieces, counts);
    g.piece_first = uint32_t(polygons.size() / 8);
    g.piece_count = 0;
    for (size_t q = 0; q < pieces.size(); ++q) {
      if (counts[q] < 3) continue;
      for (int k = 0; k < 8; ++k) {
        polygons.emplace_back(glm::vec3(pieces[q][size_t(std::min(k, counts[q] - 1))]), 0.0f);
      }
      ++g.piece_count;
    }
    g.pad = 0;
    element_texel[e] = atlas.element_texel[e];
  }
  return data;
}

}  // namespace

void GlHemisphereGather::placeCharts(const ChartAtlas& atlas, const SurfaceHierarchy& hierarchy) {
  const size_t nc = atlas.chartCount();
  chart_elements_.resize(nc);
  chart_centre_.resize(nc);
  chart_radius_.assign(nc, 0.0);
  for (size_t c = 0; c < nc; ++c) {
    const AtlasChartPlacement& pl = atlas.placement[c];
    chart_elements_[c] = glm::uvec2(pl.first_element, pl.element_count);
    const ClusterRef root = hierarchy.root(uint32_t(c));
    chart_centre_[c] = hierarchy.level(root.level).position[root.index];
    for (uint32_t e = pl.first_element; e < pl.first_element + pl.element_count; ++e) {
      chart_radius_[c] =
          std::max(chart_radius_[c], glm::length(atlas.element_position[e] - chart_centre_[c]));
    }
  }
}

Status GlHemisphereGather::createTargets(int d, const char* place) {
  incident_ = gl::texture2D(GL_RGBA32F, width_, height_);
  depth_map_ = gl::texture2D(GL_DEPTH_COMPONENT32F, d * int(tiles_), d * int(tiles_));
  glTextureParameteri(depth_map_.id(), GL_TEXTURE_COMPARE_MODE, GL_NONE);
  id_map_ = gl::texture2D(GL_R32UI, d * int(tiles_), d * int(tiles_));
  atlas_fbo_ = gl::createFramebuffer();
  glNamedFramebufferTexture(atlas_fbo_.id(), GL_COLOR_ATTACHMENT0, incident_.id(), 0);
  glNamedFramebufferDrawBuffer(atlas_fbo_.id(), GL_COLOR_ATTACHMENT0);
  depth_fbo_ = gl::createFramebuffer();
  glNamedFramebufferTexture(depth_fbo_.id(), GL_DEPTH_ATTACHMENT, depth_map_.id(), 0);
  glNamedFramebufferTexture(depth_fbo_.id(), GL_COLOR_ATTACHMENT0, id_map_.id(), 0);
  glNamedFramebufferDrawBuffer(depth_fbo_.id(), GL_COLOR_ATTACHMENT0);
  glNamedFramebufferReadBuffer(depth_fbo_.id(), GL_NONE);
  for (GLuint fbo : {atlas_fbo_.id(), depth_fbo_.id()}) {
    if (glCheckNamedFramebufferStatus(fbo, GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
      return runtimeError("", fmt::format("{}: a framebuffer is incomplete on this device", place));
    }
  }
  vao_ = gl::createVertexArray();
  return {};
}

Expected<GlHemisphereGather> GlHemisphereGather::create(
    const RadiositySurface& surface, const GlProgressiveOptions& gl_options, bool visibility,
    bool samples, const char* place, std::span<const GlBufferNeed> caller_buffers,
    uint64_t caller_texture_bytes) {
  PENUMBRA_TRY(checkGatherOptions(gl_options, place));
  GlHemisphereGather s;
  const ChartAtlas& atlas = surface.atlas;
  const FlatTriangles& flat = surface.flat;
  const size_t n = surface.elementCount();
  const uint32_t nt = uint32_t(flat.triangles.size());
  s.width_ = atlas.width;
  s.height_ = atlas.height;
  s.visibility_ = visibility;
  s.depth_tolerance_ = gl_options.depth_tolerance;
  s.visibility_resolution_ = gl_options.visibility_resolution;
  const int d = gl_options.visibility_resolution;

  // ---- Occluders: every scene triangle, tessellated for the depth pass by its size in atlas
  // texels (the longest edge at the atlas's density). ----
  const Occluders occluders = buildOccluders(atlas, flat, gl_options.tessellation_texels);
  s.far_ = occluders.far;
  s.sub_triangle_count_ = uint32_t(occluders.subs.size());
  std::vector<uint32_t> adjacency_first, adjacency;
  chartAdjacency(atlas, flat, adjacency_first, adjacency);

  // Charts: element ranges and bounding spheres, for the near pass.
  s.placeCharts(atlas, surface.hierarchy);

  // ---- Limits, before allocating ----
  int max_size = 0;
  GLint64 max_ssbo = 0;
  deviceLimits(gl_options, max_size, max_ssbo);
  const uint64_t texels = uint64_t(atlas.width) * uint64_t(atlas.height);
  // The incident atlas (RGBA32F) and the caller's atlases.
  const uint64_t atlas_bytes = texels * 16 + caller_texture_bytes;
  // A batch of tiles x tiles shooter points shares one depth texture (kMaxTiles^2 points per
  // receiver pass), as many tiles as the texture size allows.
  s.tiles_ = uint32_t(std::clamp(max_size / std::max(d, 1), 1, kMaxTiles));
  const uint64_t depth_side = uint64_t(d) * s.tiles_;
  const uint64_t depth_bytes = depth_side * depth_side * 8;  // depth and triangle id
  const uint64_t piece_count = elementPieceCount(atlas);
  const std::vector<GlBufferNeed> buffers =
      bufferNeeds(n, texels, piece_count, nt, occluders.subs.size(),
                  adjacency.size() + adjacency_first.size(), caller_buffers);
  uint64_t buffer_bytes = sizeof(GpuBatchPoint) * kMaxTiles * kMaxTiles;
  for (const GlBufferNeed& b : buffers) buffer_bytes += b.bytes;
  // Cut-outs: holes in the depth pass (raytrace/gpu_cutouts.h).
  const bool cutouts = visibility && surface.textures && surface.textures->hasCutouts();
  GpuCutoutData cutout_data;
  if (cutouts) cutout_data = buildGpuCutouts(*surface.textures, nt);
  buffer_bytes += cutout_data.bytes();
  const uint64_t total = atlas_bytes + depth_bytes + buffer_bytes;
  s.device_bytes_ = total;
  PENUMBRA_TRY(checkLimits(atlas, d, max_size, max_ssbo, atlas_bytes, buffers,
                           occluders.subs.size(), n, nt, place));
  PENUMBRA_TRY(checkDeviceMemory(total, place));

  // ---- Programs ----
  PENUMBRA_TRY(compilePrograms(visibility, samples, cutouts, s.depth_, s.receive_far_,
                               s.receive_near_, s.sample_));

  // ---- Per-element data (the CPU's elements: exact-coverage points, normals, areas,
  // reflectances and pieces) ----
  const ElementData data = elementData(surface, piece_count, s.element_texel_);

  // ---- Buffers, textures and framebuffers ----
  s.triangles_ = gl::storageBuffer(occluders.triangles);
  s.elements_ = gl::storageBuffer(data.elements);
  s.element_position_d_ = gl::storageBuffer(data.position_d);
  s.texel_chart_ = gl::storageBuffer(atlas.texel_chart);
  s.sub_triangles_ = gl::storageBuffer(occluders.subs);
  s.polygons_ = gl::storageBuffer(data.polygons);
  s.chart_adjacency_first_ = gl::storageBuffer(adjacency_first);
  s.chart_adjacency_ = gl::storageBuffer(adjacency);
  s.batch_ = gl::Buffer(sizeof(GpuBatchPoint) * kMaxTiles * kMaxTiles, nullptr);
  if (cutouts) {
    Expected<GlCutouts> c = GlCutouts::create(cutout_data, place);
    if (!c) return c.error();
    s.cutouts_ = std::move(*c);
  }
  PENUMBRA_TRY(s.createTargets(d, place));
  return s;
}

void GlHemisphereGather::setShooter(const glm::dvec3& normal, double near_factor, double far_factor,
                                    double local_factor) {
  shooter_normal_ = normal;
  setHemisphere(depth_, normal, far_);
  glProgramUniform1ui(depth_.id(), uniform(depth_, "tiles"), tiles_);
  for (const gl::Program* r : {&receive_far_, &receive_near_, &sample_}) {
    if (r->id() == 0) continue;
    const GLuint rid = r->id();
    setHemisphere(*r, normal, far_);
    glProgramUniform1ui(rid, uniform(*r, "tiles"), tiles_);
    if (visibility_) glProgramUniform1f(rid, uniform(*r, "depth_tolerance"), depth_tolerance_);
    if (r == &sample_) continue;  // the samples pass has no pairs
    glProgramUniform1f(rid, uniform(*r, "near_factor"), float(near_factor));
    glProgramUniform1f(rid, uniform(*r, "local_factor"), float(local_factor));
    if (r == &receive_far_) glProgramUniform1f(rid, uniform(*r, "far_factor"), float(far_factor));
    glProgramUniform1i(rid, uniform(*r, "count_mode"), 0);
  }
}

void GlHemisphereGather::setSamplePoints(uint32_t points) {
  if (sample_.id() == 0) return;
  glProgramUniform1ui(sample_.id(), uniform(sample_, "sample_points"), points);
}

void GlHemisphereGather::clearIncident() {
  const GLfloat zero4[4] = {0.0f, 0.0f, 0.0f, 0.0f};
  glClearTexImage(incident_.id(), 0, GL_RGBA, GL_FLOAT, zero4);
}

std::vector<glm::uvec2> GlHemisphereGather::nearCharts(
    const glm::dvec3& centre, double radius, double max_point_area, double near_factor,
    const std::vector<glm::uvec2>& ranges) const {
  // Near pairs need d^2 < near^2 A for some point of the shooter: charts whose bounding
  // spheres are farther from the shooter's than that cannot have one.
  std::vector<glm::uvec2> out;
  const double reach = near_factor * std::sqrt(max_point_area);
  for (size_t c = 0; c < chart_elements_.size(); ++c) {
    const double gap = glm::length(chart_centre_[c] - centre) - chart_radius_[c] - radius;
    if (gap < reach * (1.0 + 1e-6) && ranges[c].y > 0) out.push_back(ranges[c]);
  }
  return out;
}

void GlHemisphereGather::prepareBatch(std::span<const GpuBatchPoint> points) {
  const uint32_t count = uint32_t(std::min<size_t>(points.size(), batchSize()));
  std::array<GpuBatchPoint, kMaxTiles * kMaxTiles> batch{};
  std::copy_n(points.begin(), count, batch.begin());
  ++batches_;
  for (uint32_t k = 0; k < count; ++k) {
    GpuBatchPoint& b = batch[k];
    const glm::dvec3 eye = cutouts_ ? cutoutJitter(shooter_normal_, b.position[3],
                                                   batches_ << 32 | (uint64_t(b.members[0]) + k))
                                    : glm::dvec3(0.0);
    for (int c = 0; c < 3; ++c) b.eye[c] = float(eye[c]);
    b.eye[3] = 0.0f;
  }
  batch_.upload(batch.data(), count * sizeof(GpuBatchPoint));
  batch_.bindBase(GL_UNIFORM_BUFFER, PROGRESSIVE_UBO_BATCH);
  for (const gl::Program* r : {&receive_far_, &receive_near_, &sample_}) {
    if (r->id() != 0) glProgramUniform1ui(r->id(), uniform(*r, "batch_count"), count);
  }
  if (!visibility_) return;
  // Algorithm 1: the scene's depth from each point of the batch, hemispherical projection, one
  // instance (and one tile of the depth texture) per point.
  const GLint d = visibility_resolution_ * GLint(tiles_);
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
  if (cutouts_) cutouts_->bind(PROGRESSIVE_SSBO_CUTOUTS);
  glBindVertexArray(vao_.id());
  glDrawArraysInstanced(GL_TRIANGLES, 0, GLsizei(6 * sub_triangle_count_), GLsizei(count));
  glBindVertexArray(0);
  for (int c = 0; c < 4; ++c) glDisable(GLenum(GL_CLIP_DISTANCE0 + c));
  glDisable(GL_DEPTH_TEST);
}

void GlHemisphereGather::draw(Pass pass, uint32_t first, uint32_t count, const Receivers& receivers,
                              GLuint sent, const gl::Buffer* samples) {
  if (count == 0) return;
  const gl::Program& program = pass == Pass::kFar    ? receive_far_
                               : pass == Pass::kNear ? receive_near_
                                                     : sample_;
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
  const bool own = receivers.receivers == nullptr;
  (own ? elements_ : *receivers.receivers)
      .bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_RECEIVERS);
  (own ? element_position_d_ : *receivers.positions)
      .bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_ELEMENT_POSITION_D);
  if (samples) samples->bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_SAMPLES);
  polygons_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_POLYGONS);
  batch_.bindBase(GL_UNIFORM_BUFFER, PROGRESSIVE_UBO_BATCH);
  glBindTextureUnit(PROGRESSIVE_TEXTURE_DEPTH_MAP, depth_map_.id());
  glBindTextureUnit(PROGRESSIVE_TEXTURE_RESIDUAL_MAP, sent);
  glBindTextureUnit(PROGRESSIVE_TEXTURE_ID_MAP, id_map_.id());
  texel_chart_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_TEXEL_CHART);
  chart_adjacency_first_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_ADJACENCY_FIRST);
  chart_adjacency_.bindBase(GL_SHADER_STORAGE_BUFFER, PROGRESSIVE_SSBO_ADJACENCY);
  if (cutouts_) cutouts_->bind(PROGRESSIVE_SSBO_CUTOUTS);
  glBindVertexArray(vao_.id());
  // One point of size 1 at each receiver's texel centre: exactly one fragment per receiver (the
  // paper rasterises the receiver triangles through their lightmap UVs; every fragment of a
  // texel computes the same value from its element's data, so one per texel is what counts).
  glDisable(GL_PROGRAM_POINT_SIZE);
  glPointSize(1.0f);
  glDrawArrays(GL_POINTS, GLint(first), GLsizei(count));
  glBindVertexArray(0);
  glDisable(GL_BLEND);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

Expected<std::vector<uint32_t>> GlHemisphereGather::coverage(GLuint sent) {
  clearIncident();
  const gl::Program& r = receive_far_;
  glProgramUniform1i(r.id(), uniform(r, "count_mode"), 1);
  draw(Pass::kFar, 0, uint32_t(element_texel_.size()), Receivers{}, sent);
  glProgramUniform1i(r.id(), uniform(r, "count_mode"), 0);
  glUseProgram(0);
  std::vector<glm::vec4> rgba;
  glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT);
  gl::readRGBA32F(incident_.id(), width_, height_, rgba);
  clearIncident();
  if (const GLenum err = glGetError(); err != GL_NO_ERROR) {
    return runtimeError("", fmt::format("OpenGL error 0x{:x} while rendering the receiver "
                                        "coverage",
                                        err));
  }
  std::vector<uint32_t> out(element_texel_.size());
  for (size_t e = 0; e < out.size(); ++e) {
    out[e] = uint32_t(std::lround(rgba[element_texel_[e]].x));
  }
  return out;
}

}  // namespace penumbra
