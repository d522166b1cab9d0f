#include "penumbra/scene/surface_textures.h"

#include <glm/common.hpp>

#include <algorithm>
#include <cmath>

namespace penumbra {

namespace {

// A mean over a triangle samples it at the centroids of the k^2 similar triangles it divides
// into (a stratified midpoint rule, exact for functions linear over the triangle), with k about
// the square root of the texels it covers, from 3 to 16: up to 256 samples, one per texel of the
// finest level while that suffices. Beyond, each texture is read on a coarser level whose texels
// are twice the samples' spacing, so its bilinear reconstruction holds no detail the samples
// would alias (the pyramid keeps the mean).
constexpr int kMinGrid = 3;
constexpr int kMaxGrid = 16;

// The area in texels of level 0 of a triangle of image coordinates st[0..2].
double texelArea(const Texture& texture, const glm::vec2 st[3]) {
  const glm::vec2 e1 = st[1] - st[0], e2 = st[2] - st[0];
  return 0.5 * std::abs(double(e1.x) * e2.y - double(e1.y) * e2.x) * double(texture.width()) *
         double(texture.height());
}

// The level to read a texture at with `samples` samples over `area` texels.
float meanLevel(const Texture& texture, double area, int samples) {
  if (area <= samples) return 0.0f;
  const double level = 0.5 * std::log2(area / samples) + 1.0;
  return float(std::min(level, double(texture.levelCount() - 1)));
}

// The channel of a coverage texture (MTL map_d) that holds coverage: alpha when its file has one,
// else the first (a grey mask).
int coverageChannel(const Texture& t) {
  return t.fileChannels() == 2 || t.fileChannels() == 4 ? 3 : 0;
}

// A convex polygon's centroid (area-weighted over its fan; its first corner when degenerate).
glm::dvec2 polygonCentroid(std::span<const glm::vec2> polygon) {
  glm::dvec2 centroid(0.0);
  double area = 0.0;
  for (size_t k = 1; k + 1 < polygon.size(); ++k) {
    const glm::dvec2 a(polygon[0]), b(polygon[k]), c(polygon[k + 1]);
    const double w = 0.5 * std::abs((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
    centroid += w * (a + b + c) / 3.0;
    area += w;
  }
  if (area > 0.0) return centroid / area;
  return polygon.empty() ? glm::dvec2(0.0) : glm::dvec2(polygon[0]);
}

}  // namespace

SurfaceTextures::SurfaceTextures(const Scene& scene) {
  materials_ = scene.materials;
  std::vector<uint32_t> sets;  // UV sets some material reads
  for (const Material& m : materials_) {
    for (const auto* binding : {&m.reflectance_texture, &m.emission_texture, &m.coverage_texture}) {
      if (*binding && std::find(sets.begin(), sets.end(), (*binding)->uv_set) == sets.end()) {
        sets.push_back((*binding)->uv_set);
      }
    }
  }
  uint32_t max_set = 0;
  for (uint32_t s : sets) max_set = std::max(max_set, s + 1);
  bool colours = false;
  for (const Mesh& mesh : scene.meshes) colours = colours || !mesh.colors.empty();

  const size_t n = scene.triangleCount();
  material_ids_.reserve(n);
  flags_.reserve(n);
  corner_uvs_.resize(max_set);
  has_uvs_.resize(max_set);
  for (uint32_t s : sets) {
    corner_uvs_[s].reserve(3 * n);
    has_uvs_[s].reserve(n);
  }
  if (colours) corner_colours_.reserve(3 * n);
  for (const Mesh& mesh : scene.meshes) {
    for (size_t t = 0; t < mesh.triangles.size(); ++t) {
      const glm::uvec3 tri = mesh.triangles[t];
      const uint32_t id = mesh.material_ids[t];
      const Material& m = materials_[id];
      uint8_t flags = 0;
      if (m.isTextured() || !mesh.colors.empty()) flags |= kVaries;
      if (m.hasCutouts() || (m.alpha_mode != AlphaMode::kOpaque && !mesh.colors.empty())) {
        flags |= kCutout;
      }
      if (mesh.uv_origin_top) flags |= kOriginTop;
      if (!mesh.colors.empty()) flags |= kColours;
      any_ = any_ || (flags & kVaries);
      cutouts_ = cutouts_ || (flags & kCutout);
      material_ids_.push_back(id);
      flags_.push_back(flags);
      for (uint32_t s : sets) {
        const std::vector<glm::vec2>& uvs = mesh.uvSet(s);
        has_uvs_[s].push_back(uvs.empty() ? 0 : 1);
        for (int k = 0; k < 3; ++k) {
          corner_uvs_[s].push_back(uvs.empty() ? glm::vec2(0.0f) : uvs[tri[k]]);
        }
      }
      if (colours) {
        for (int k = 0; k < 3; ++k) {
          corner_colours_.push_back(mesh.colors.empty() ? glm::vec4(1.0f) : mesh.colors[tri[k]]);
        }
      }
    }
  }
}

bool SurfaceTextures::imageCoordinates(uint32_t tri, const TextureBinding& binding, glm::vec2 b,
                                       glm::vec2& st) const {
  const uint32_t s = binding.uv_set;
  if (!has_uvs_[s][tri]) return false;
  const glm::vec2* c = corner_uvs_[s].data() + 3 * size_t(tri);
  const glm::vec2 uv = (1.0f - b.x - b.y) * c[0] + b.x * c[1] + b.y * c[2];
  st = binding.imageCoordinates(uv, (flags_[tri] & kOriginTop) != 0);
  return true;
}

glm::vec4 SurfaceTextures::colour(uint32_t tri, glm::vec2 b) const {
  if (!(flags_[tri] & kColours)) return glm::vec4(1.0f);
  const glm::vec4* c = corner_colours_.data() + 3 * size_t(tri);
  return (1.0f - b.x - b.y) * c[0] + b.x * c[1] + b.y * c[2];
}

glm::vec3 SurfaceTextures::reflectance(uint32_t tri, glm::vec2 b) const {
  const Material& m = material(tri);
  if (!(flags_[tri] & kVaries)) return m.reflectance;
  glm::vec3 r = m.reflectance * glm::vec3(colour(tri, b));
  if (m.reflectance_texture) {
    const TextureBinding& binding = *m.reflectance_texture;
    glm::vec2 st;
    r *= imageCoordinates(tri, binding, b, st)
             ? glm::vec3(sampleTexture(*binding.texture, binding.sampler, st))
             : glm::vec3(binding.texture->mean());
  }
  return r;
}

glm::vec3 SurfaceTextures::emission(uint32_t tri, glm::vec2 b) const {
  const Material& m = material(tri);
  if (!m.emission_texture) return m.emission;
  const TextureBinding& binding = *m.emission_texture;
  glm::vec2 st;
  return m.emission * (imageCoordinates(tri, binding, b, st)
                           ? glm::vec3(sampleTexture(*binding.texture, binding.sampler, st))
                           : glm::vec3(binding.texture->mean()));
}

float SurfaceTextures::coverageOf(const Material& m, uint32_t tri, glm::vec2 b,
                                  const glm::vec4& base) const {
  float a = m.alpha * (m.alpha_from_reflectance ? base.w : 1.0f) * colour(tri, b).w;
  if (m.coverage_texture) {
    const TextureBinding& binding = *m.coverage_texture;
    const Texture& tex = *binding.texture;
    const int channel = coverageChannel(tex);
    glm::vec2 st;
    a *= imageCoordinates(tri, binding, b, st) ? sampleTexture(tex, binding.sampler, st)[channel]
                                               : tex.mean()[channel];
  }
  return a;
}

float SurfaceTextures::alpha(uint32_t tri, glm::vec2 b) const {
  const Material& m = material(tri);
  if (m.alpha_mode == AlphaMode::kOpaque) return 1.0f;
  glm::vec4 base(1.0f);
  if (m.reflectance_texture) {
    const TextureBinding& binding = *m.reflectance_texture;
    glm::vec2 st;
    base = imageCoordinates(tri, binding, b, st)
               ? sampleTexture(*binding.texture, binding.sampler, st)
               : binding.texture->mean();
  }
  return coverageOf(m, tri, b, base);
}

bool SurfaceTextures::stops(uint32_t tri, glm::vec2 b, float u) const {
  if (!(flags_[tri] & kCutout)) return true;
  const Material& m = material(tri);
  const float a = alpha(tri, b);
  return m.alpha_mode == AlphaMode::kMask ? a >= m.alpha_cutoff : u < a;
}

SurfaceTextures::CutoutSource SurfaceTextures::cutoutSource(uint32_t tri) const {
  const Material& m = material(tri);
  const glm::vec2 corners[3] = {glm::vec2(0.0f), glm::vec2(1.0f, 0.0f), glm::vec2(0.0f, 1.0f)};
  CutoutSource out;
  float constant = m.alpha;
  // As alpha() and coverageOf() read them: the base colour's alpha when the material takes its
  // coverage from there, times the coverage texture's channel.
  const auto lookup = [&](const TextureBinding& binding, int channel, CutoutSource::Lookup& l) {
    const Texture& tex = *binding.texture;
    if (!has_uvs_[binding.uv_set][tri]) {
      constant *= tex.mean()[channel];
      return;
    }
    if (channel == 3 && !tex.hasAlpha()) return;
    l.binding = &binding;
    l.channel = channel;
    for (int c = 0; c < 3; ++c) imageCoordinates(tri, binding, corners[c], l.st[c]);
  };
  if (m.alpha_mode != AlphaMode::kOpaque) {
    if (m.alpha_from_reflectance && m.reflectance_texture) {
      lookup(*m.reflectance_texture, 3, out.lookups[0]);
    }
    if (m.coverage_texture) {
      lookup(*m.coverage_texture, coverageChannel(*m.coverage_texture->texture), out.lookups[1]);
    }
  }
  for (int c = 0; c < 3; ++c) out.factor[c] = constant * colour(tri, corners[c]).w;
  return out;
}

SurfaceTextures::Mean SurfaceTextures::triangleMean(uint32_t tri, bool factors) const {
  const glm::vec2 corners[3] = {glm::vec2(0.0f), glm::vec2(1.0f, 0.0f), glm::vec2(0.0f, 1.0f)};
  return mean(tri, corners, factors);
}

SurfaceTextures::Mean SurfaceTextures::mean(uint32_t tri, std::span<const glm::vec2> polygon,
                                            bool factors) const {
  const Material& m = material(tri);
  const glm::vec3 reflectance_factor = factors ? m.reflectance : glm::vec3(1.0f);
  const glm::vec3 emission_factor = factors ? m.emission : glm::vec3(1.0f);
  Mean out;
  out.covered_centroid = polygonCentroid(polygon);  // when it covers all or nothing
  if (!(flags_[tri] & (kVaries | kCutout)) || polygon.size() < 3) {
    out.reflectance = glm::dvec3(reflectance_factor);
    out.emission = glm::dvec3(emission_factor);
    return out;
  }
  const bool mask = m.alpha_mode == AlphaMode::kMask;
  const bool covers = m.alpha_mode != AlphaMode::kOpaque;
  glm::dvec3 r_sum(0.0), e_sum(0.0);
  glm::dvec2 p_sum(0.0);  // coverage-weighted points
  double c_sum = 0.0, weight_sum = 0.0;
  for (size_t k = 1; k + 1 < polygon.size(); ++k) {
    const glm::vec2 b[3] = {polygon[0], polygon[k], polygon[k + 1]};
    const glm::vec2 e1 = b[1] - b[0], e2 = b[2] - b[0];
    const double weight = 0.5 * std::abs(double(e1.x) * e2.y - double(e1.y) * e2.x);
    if (!(weight > 0.0)) continue;
    // Each binding's image coordinates at the piece's corners, the texels it covers, and (once
    // the sample count is known) the level to read.
    struct Slot {
      const TextureBinding* binding = nullptr;
      bool mapped = false;
      double area = 0.0;
      float level = 0.0f;
    };
    auto slot = [&](const std::optional<TextureBinding>& binding) {
      Slot s;
      if (!binding) return s;
      s.binding = &*binding;
      glm::vec2 st[3];
      s.mapped = true;
      for (int c = 0; c < 3; ++c) {
        s.mapped = s.mapped && imageCoordinates(tri, *binding, b[c], st[c]);
      }
      if (s.mapped) s.area = texelArea(*binding->texture, st);
      return s;
    };
    Slot base = slot(m.reflectance_texture);
    Slot glow = slot(m.emission_texture);
    Slot cover = slot(m.coverage_texture);
    const double most = std::max({base.area, glow.area, cover.area, 1.0});
    const int grid = std::clamp(int(std::ceil(std::sqrt(most))), kMinGrid, kMaxGrid);
    const int samples = grid * grid;
    for (Slot* s : {&base, &glow, &cover}) {
      if (s->mapped) s->level = meanLevel(*s->binding->texture, s->area, samples);
    }
    auto read = [&](const Slot& s, glm::vec2 p, float level) {
      glm::vec2 st;
      imageCoordinates(tri, *s.binding, p, st);
      return sampleTextureTrilinear(*s.binding->texture, s.binding->sampler, st, level);
    };
    glm::dvec3 r_piece(0.0), e_piece(0.0);
    glm::dvec2 p_piece(0.0);
    double c_piece = 0.0;
    for (int i = 0; i < grid; ++i) {
      for (int j = 0; j < grid - i; ++j) {
        for (int down = 0; down < (i + j < grid - 1 ? 2 : 1); ++down) {
          const float a = (float(i) + (down ? 2.0f : 1.0f) / 3.0f) / float(grid);
          const float c = (float(j) + (down ? 2.0f : 1.0f) / 3.0f) / float(grid);
          const glm::vec2 p = b[0] + a * e1 + c * e2;
          const glm::vec4 vertex = colour(tri, p);
          glm::vec3 r = reflectance_factor * glm::vec3(vertex);
          float alpha = m.alpha * vertex.w;
          if (base.binding) {
            // A cut-out's coverage is a step of alpha, which needs the finest level; the colour
            // it multiplies is read there too, so the covered part's colour is not mixed with
            // the holes'. Partial coverage is linear in alpha: any level keeps its mean.
            const bool step = mask && m.alpha_from_reflectance;
            const glm::vec4 t = base.mapped ? read(base, p, step ? 0.0f : base.level)
                                            : base.binding->texture->mean();
            r *= glm::vec3(t);
            if (covers && m.alpha_from_reflectance) alpha *= t.w;
          }
          if (cover.binding) {
            const Texture& tex = *cover.binding->texture;
            const int channel = coverageChannel(tex);
            alpha *= cover.mapped ? read(cover, p, mask ? 0.0f : cover.level)[channel]
                                  : tex.mean()[channel];
          }
          double coverage = 1.0;
          if (covers) coverage = mask ? (alpha >= m.alpha_cutoff ? 1.0 : 0.0) : double(alpha);
          glm::vec3 e = emission_factor;
          if (glow.binding) {
            e *= glm::vec3(glow.mapped ? read(glow, p, glow.level) : glow.binding->texture->mean());
          }
          r_piece += glm::dvec3(r) * coverage;
          e_piece += glm::dvec3(e) * coverage;
          p_piece += glm::dvec2(p) * coverage;
          c_piece += coverage;
        }
      }
    }
    r_sum += weight * r_piece / double(samples);
    e_sum += weight * e_piece / double(samples);
    c_sum += weight * c_piece / double(samples);
    p_sum += weight * p_piece / double(samples);
    weight_sum += weight;
  }
  if (!(weight_sum > 0.0)) {
    out.reflectance = glm::dvec3(reflectance_factor);
    out.emission = glm::dvec3(emission_factor);
    return out;
  }
  out.reflectance = r_sum / weight_sum;
  out.emission = e_sum / weight_sum;
  out.coverage = c_sum / weight_sum;
  if (c_sum > 0.0) out.covered_centroid = p_sum / c_sum;
  return out;
}

}  // namespace penumbra
