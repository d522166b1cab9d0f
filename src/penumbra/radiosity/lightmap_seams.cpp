#include "penumbra/radiosity/lightmap_seams.h"

#include "penumbra/core/color.h"
#include "penumbra/radiosity/radiosity_surface.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <numbers>
#include <unordered_map>

namespace penumbra {

namespace {

// Normals of the two faces of a seam within this angle: the surface is continuous there.
constexpr double kSeamCosine = 0.8660254037844387;  // cos 30 degrees

// One point on a seam: the bilinear lookup on side A minus that on side B, as weights on texels.
struct SeamSample {
  std::array<uint32_t, 8> texel{};
  std::array<double, 8> weight{};
  int count = 0;

  void add(uint32_t t, double w) {
    for (int i = 0; i < count; ++i) {
      if (texel[size_t(i)] == t) {
        weight[size_t(i)] += w;
        return;
      }
    }
    texel[size_t(count)] = t;
    weight[size_t(count)] = w;
    ++count;
  }
  template <typename Read>
  double residual(Read&& read) const {
    double r = 0.0;
    for (int i = 0; i < count; ++i) r += weight[size_t(i)] * read(texel[size_t(i)]);
    return r;
  }
};

void addBilinear(SeamSample& s, glm::dvec2 uv, int width, int height, double sign) {
  const double fx = uv.x * width - 0.5, fy = uv.y * height - 0.5;
  const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
  const double ax = fx - x0, ay = fy - y0;
  const auto at = [&](int x, int y) {
    return uint32_t(std::clamp(y, 0, height - 1)) * uint32_t(width) +
           uint32_t(std::clamp(x, 0, width - 1));
  };
  s.add(at(x0, y0), sign * (1 - ax) * (1 - ay));
  s.add(at(x0 + 1, y0), sign * ax * (1 - ay));
  s.add(at(x0, y0 + 1), sign * (1 - ax) * ay);
  s.add(at(x0 + 1, y0 + 1), sign * ax * ay);
}

using PointKey = std::array<uint32_t, 3>;
struct EdgeKey {
  PointKey a, b;
  bool back = false;
  bool operator==(const EdgeKey&) const = default;
};
struct EdgeHash {
  size_t operator()(const EdgeKey& k) const {
    uint64_t h = k.back ? 0x9e3779b97f4a7c15ull : 1469598103934665603ull;
    for (uint32_t v : k.a) h = (h ^ v) * 1099511628211ull;
    for (uint32_t v : k.b) h = (h ^ v) * 1099511628211ull;
    return size_t(h);
  }
};

PointKey keyOf(const glm::vec3& p) {
  return {std::bit_cast<uint32_t>(p.x), std::bit_cast<uint32_t>(p.y), std::bit_cast<uint32_t>(p.z)};
}

// Points every half texel along every seam edge of the atlas.
std::vector<SeamSample> seamSamples(const RadiositySurface& s, size_t* edges) {
  const ChartAtlas& atlas = s.atlas;
  const auto& positions = s.flat.positions;
  std::unordered_map<EdgeKey, std::pair<uint32_t, int>, EdgeHash> first;
  std::vector<SeamSample> samples;
  *edges = 0;
  const auto normalOf = [&](uint32_t f) {
    const glm::uvec3 t = s.flat.triangles[atlas.faces[f].triangle];
    const glm::dvec3 n = glm::cross(glm::dvec3(positions[t.y] - positions[t.x]),
                                    glm::dvec3(positions[t.z] - positions[t.x]));
    const double len = glm::length(n);
    return (len > 0.0 ? n / len : n) * (atlas.faces[f].back ? -1.0 : 1.0);
  };
  for (uint32_t f = 0; f < atlas.faces.size(); ++f) {
    if (atlas.charts.face_chart[f] < 0) continue;
    const glm::uvec3 t = s.flat.triangles[atlas.faces[f].triangle];
    for (int k = 0; k < 3; ++k) {
      const glm::vec3 p0 = positions[t[k]], p1 = positions[t[(k + 1) % 3]];
      EdgeKey key{keyOf(p0), keyOf(p1), atlas.faces[f].back};
      if (key.b < key.a) std::swap(key.a, key.b);
      auto [it, fresh] = first.emplace(key, std::make_pair(f, k));
      if (fresh) continue;
      const uint32_t g = it->second.first;
      const int m = it->second.second;
      if (atlas.charts.face_chart[g] == atlas.charts.face_chart[f]) continue;
      if (glm::dot(normalOf(f), normalOf(g)) < kSeamCosine) continue;
      // Side A: face f's edge k from p0 to p1; side B: face g's edge m, aligned to it.
      const glm::uvec3 tg = s.flat.triangles[atlas.faces[g].triangle];
      glm::dvec2 a0(atlas.uvs[3 * size_t(f) + size_t(k)]);
      glm::dvec2 a1(atlas.uvs[3 * size_t(f) + size_t((k + 1) % 3)]);
      glm::dvec2 b0(atlas.uvs[3 * size_t(g) + size_t(m)]);
      glm::dvec2 b1(atlas.uvs[3 * size_t(g) + size_t((m + 1) % 3)]);
      if (keyOf(positions[tg[m]]) != keyOf(p0)) std::swap(b0, b1);
      const double texels = glm::length((a1 - a0) * glm::dvec2(atlas.width, atlas.height));
      const int n = std::max(2, int(std::ceil(2.0 * texels)));
      for (int i = 0; i < n; ++i) {
        const double u = (i + 0.5) / n;
        SeamSample sample;
        addBilinear(sample, a0 + u * (a1 - a0), atlas.width, atlas.height, 1.0);
        addBilinear(sample, b0 + u * (b1 - b0), atlas.width, atlas.height, -1.0);
        samples.push_back(sample);
      }
      ++*edges;
    }
  }
  return samples;
}

double lum(const glm::vec3& c) {
  return luminance(glm::dvec3(c));
}

// The largest and RMS jump (luminance) over the samples; read(t) gives the texel t a sample
// names.
template <typename Read>
void jumps(const std::vector<SeamSample>& samples, Read&& read, double* largest, double* rms) {
  double sq = 0.0;
  *largest = 0.0;
  for (const SeamSample& s : samples) {
    const double r = s.residual(read);
    *largest = std::max(*largest, std::abs(r));
    sq += r * r;
  }
  *rms = samples.empty() ? 0.0 : std::sqrt(sq / double(samples.size()));
}

}  // namespace

SeamStats measureSeams(const RadiositySurface& surface, const Image& image) {
  SeamStats st;
  const std::vector<SeamSample> samples = seamSamples(surface, &st.edges);
  st.samples = samples.size();
  const auto luminanceOf = [&](uint32_t t) { return lum(image.pixels[t]); };
  jumps(samples, luminanceOf, &st.jump_before, &st.rms_before);
  st.jump_after = st.jump_before;
  st.rms_after = st.rms_before;
  return st;
}

SeamStats stitchSeams(const RadiositySurface& surface, Image& image, double lambda) {
  SeamStats st;
  std::vector<SeamSample> samples = seamSamples(surface, &st.edges);
  st.samples = samples.size();
  jumps(
      samples, [&](uint32_t t) { return lum(image.pixels[t]); }, &st.jump_before, &st.rms_before);
  // The texels the seams read become the unknowns.
  std::unordered_map<uint32_t, uint32_t> variable;
  std::vector<uint32_t> texel_of;
  for (SeamSample& s : samples) {
    for (int i = 0; i < s.count; ++i) {
      auto [it, fresh] = variable.emplace(s.texel[size_t(i)], uint32_t(texel_of.size()));
      if (fresh) texel_of.push_back(s.texel[size_t(i)]);
      s.texel[size_t(i)] = it->second;
    }
  }
  const size_t n = texel_of.size();
  st.texels = n;
  // (A^T A + lambda I) x = lambda x0 per channel, by conjugate gradients from x0.
  const auto apply = [&](const std::vector<double>& x, std::vector<double>& y) {
    for (size_t i = 0; i < n; ++i) y[i] = lambda * x[i];
    for (const SeamSample& s : samples) {
      const double r = s.residual([&](uint32_t v) { return x[v]; });
      for (int i = 0; i < s.count; ++i) y[s.texel[size_t(i)]] += s.weight[size_t(i)] * r;
    }
  };
  for (int c = 0; c < 3 && n > 0; ++c) {
    std::vector<double> x0(n), x(n), r(n), p(n), q(n);
    for (size_t i = 0; i < n; ++i) x0[i] = x[i] = image.pixels[texel_of[i]][c];
    apply(x, q);
    double rr = 0.0, bb = 0.0;
    for (size_t i = 0; i < n; ++i) {
      r[i] = lambda * x0[i] - q[i];
      p[i] = r[i];
      rr += r[i] * r[i];
      bb += (lambda * x0[i]) * (lambda * x0[i]);
    }
    for (int it = 0; it < 500 && rr > 1e-20 * std::max(bb, 1e-30); ++it) {
      apply(p, q);
      double pq = 0.0;
      for (size_t i = 0; i < n; ++i) pq += p[i] * q[i];
      if (!(pq > 0.0)) break;
      const double alpha = rr / pq;
      double next = 0.0;
      for (size_t i = 0; i < n; ++i) {
        x[i] += alpha * p[i];
        r[i] -= alpha * q[i];
        next += r[i] * r[i];
      }
      const double beta = next / rr;
      rr = next;
      for (size_t i = 0; i < n; ++i) p[i] = r[i] + beta * p[i];
    }
    for (size_t i = 0; i < n; ++i) image.pixels[texel_of[i]][c] = float(std::max(0.0, x[i]));
  }
  // The jumps after, on the texels as written (the samples now name unknowns).
  jumps(
      samples, [&](uint32_t v) { return lum(image.pixels[texel_of[v]]); }, &st.jump_after,
      &st.rms_after);
  return st;
}

}  // namespace penumbra
