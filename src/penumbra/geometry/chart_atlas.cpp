#include "penumbra/geometry/chart_atlas.h"

#include "penumbra/core/check.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/parallel.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <limits>
#include <numeric>

namespace penumbra {

namespace {

// A chart rasterised in its own texel frame: local texel (x, y) is atlas texel origin + (x, y).
struct ChartRaster {
  int w = 0, h = 0;
  glm::dvec2 uv_min{0.0};       // the chart's UV bounding box corner (metres)
  std::vector<uint8_t> kind;    // 0 outside the footprint, 1 border, 2 covered
  std::vector<int32_t> face;    // nearest face to the centre
  std::vector<float> distance;  // its distance (texels)
  std::vector<glm::vec2> barycentric;
  std::vector<double> area;      // m^2
  std::vector<double> uv_cover;  // texel^2, summed over faces (> 1: the chart overlaps itself)
  std::vector<glm::dvec3> position, normal;  // sums weighted by area
  std::vector<double> largest;               // the largest piece's area, its face
  std::vector<int32_t> largest_face;
  std::vector<std::pair<uint32_t, uint32_t>> overlaps;  // (local texel, face)
  bool overlapping = false;
};

double cross2(const glm::dvec2& a, const glm::dvec2& b) {
  return a.x * b.y - a.y * b.x;
}

// Whether triangle (a, b, c) and the closed rectangle [lo, hi] intersect (separating axes: the
// rectangle's two and the triangle's three edge normals).
bool triangleTouchesRect(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c,
                         const glm::dvec2& lo, const glm::dvec2& hi) {
  if (std::max({a.x, b.x, c.x}) < lo.x || std::min({a.x, b.x, c.x}) > hi.x) return false;
  if (std::max({a.y, b.y, c.y}) < lo.y || std::min({a.y, b.y, c.y}) > hi.y) return false;
  const glm::dvec2 v[3] = {a, b, c};
  const glm::dvec2 r[4] = {lo, {hi.x, lo.y}, hi, {lo.x, hi.y}};
  for (int k = 0; k < 3; ++k) {
    const glm::dvec2 e = v[(k + 1) % 3] - v[k];
    const glm::dvec2 n(-e.y, e.x);
    double tmin = std::numeric_limits<double>::max(), tmax = -tmin;
    for (const glm::dvec2& p : v) {
      tmin = std::min(tmin, glm::dot(n, p));
      tmax = std::max(tmax, glm::dot(n, p));
    }
    double rmin = std::numeric_limits<double>::max(), rmax = -rmin;
    for (const glm::dvec2& p : r) {
      rmin = std::min(rmin, glm::dot(n, p));
      rmax = std::max(rmax, glm::dot(n, p));
    }
    if (rmax < tmin || rmin > tmax) return false;
  }
  return true;
}

// Distance from p to the triangle (a, b, c) (0 inside), and p's barycentrics (w1, w2),
// extrapolated when outside.
double pointTriangle(const glm::dvec2& p, const glm::dvec2& a, const glm::dvec2& b,
                     const glm::dvec2& c, glm::dvec2& bary) {
  const glm::dvec2 e1 = b - a, e2 = c - a, d = p - a;
  const double det = cross2(e1, e2);
  if (det == 0.0) {
    bary = glm::dvec2(0.0);
    return glm::length(d);
  }
  const double w1 = cross2(d, e2) / det, w2 = cross2(e1, d) / det, w0 = 1.0 - w1 - w2;
  bary = glm::dvec2(w1, w2);
  if (w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0) return 0.0;
  auto segment = [&](const glm::dvec2& s, const glm::dvec2& t) {
    const glm::dvec2 st = t - s;
    const double l2 = glm::dot(st, st);
    const double u = l2 > 0.0 ? std::clamp(glm::dot(p - s, st) / l2, 0.0, 1.0) : 0.0;
    return glm::length(p - (s + u * st));
  };
  return std::min({segment(a, b), segment(b, c), segment(c, a)});
}

// The chart's corner texel coordinates for `density`: UV (metres) - uv_min, scaled, plus a
// margin of one texel for the footprint's border ring.
glm::dvec2 localTexel(const glm::dvec2& uv, const glm::dvec2& uv_min, double density) {
  return (uv - uv_min) * density + glm::dvec2(1.0);
}

ChartRaster rasterise(const ChartSet& set, size_t c, double density,
                      std::span<const glm::vec3> positions, std::span<const glm::uvec3> triangles,
                      std::span<const SurfaceFace> faces, bool full) {
  const Chart& chart = set.charts[c];
  ChartRaster r;
  glm::dvec2 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  for (uint32_t f : chart.faces) {
    for (int k = 0; k < 3; ++k) {
      lo = glm::min(lo, set.uv[3 * size_t(f) + size_t(k)]);
      hi = glm::max(hi, set.uv[3 * size_t(f) + size_t(k)]);
    }
  }
  r.uv_min = lo;
  const glm::dvec2 top = localTexel(hi, lo, density);
  r.w = int(std::floor(top.x + 0.5)) + 1;
  r.h = int(std::floor(top.y + 0.5)) + 1;
  const size_t n = size_t(r.w) * size_t(r.h);
  r.kind.assign(n, 0);
  if (full) {
    r.face.assign(n, -1);
    r.distance.assign(n, std::numeric_limits<float>::max());
    r.barycentric.assign(n, glm::vec2(0.0f));
    r.area.assign(n, 0.0);
    r.uv_cover.assign(n, 0.0);
    r.position.assign(n, glm::dvec3(0.0));
    r.normal.assign(n, glm::dvec3(0.0));
    r.largest.assign(n, 0.0);
    r.largest_face.assign(n, -1);
  }
  for (uint32_t f : chart.faces) {
    glm::dvec2 t[3];
    for (int k = 0; k < 3; ++k) {
      // Corners shared by faces are one value in set.uv, so they agree exactly here.
      t[k] = localTexel(set.uv[3 * size_t(f) + size_t(k)], lo, density);
    }
    const glm::uvec3 tri = triangles[faces[f].triangle];
    const glm::dvec3 p0(positions[tri.x]), p1(positions[tri.y]), p2(positions[tri.z]);
    glm::dvec3 nrm = glm::cross(p1 - p0, p2 - p0);
    const double area3 = 0.5 * glm::length(nrm);
    const double area_uv = 0.5 * std::abs(cross2(t[1] - t[0], t[2] - t[0]));
    if (!(area3 > 0.0) || !(area_uv > 0.0)) continue;
    nrm /= 2.0 * area3;
    if (faces[f].back) nrm = -nrm;
    const glm::dvec2 bmin = glm::min(t[0], glm::min(t[1], t[2]));
    const glm::dvec2 bmax = glm::max(t[0], glm::max(t[1], t[2]));
    const int x0 = std::max(0, int(std::ceil(bmin.x - 1.5))),
              x1 = std::min(r.w - 1, int(std::floor(bmax.x + 0.5)));
    const int y0 = std::max(0, int(std::ceil(bmin.y - 1.5))),
              y1 = std::min(r.h - 1, int(std::floor(bmax.y + 0.5)));
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        if (!triangleTouchesRect(t[0], t[1], t[2], glm::dvec2(x - 0.5, y - 0.5),
                                 glm::dvec2(x + 1.5, y + 1.5))) {
          continue;
        }
        const size_t i = size_t(y) * size_t(r.w) + size_t(x);
        if (r.kind[i] == 0) r.kind[i] = 1;
        if (!full) {
          // The footprint alone (for packing trials): covered texels are footprint as well.
          continue;
        }
        glm::dvec2 bary;
        const float d = float(pointTriangle(glm::dvec2(x + 0.5, y + 0.5), t[0], t[1], t[2], bary));
        if (d < r.distance[i]) {
          r.distance[i] = d;
          r.face[i] = int32_t(f);
          r.barycentric[i] = glm::vec2(bary);
        }
        glm::dvec2 poly[8];
        const int m = clipTriangleToRect(t[0], t[1], t[2], glm::dvec2(x, y),
                                         glm::dvec2(x + 1.0, y + 1.0), poly);
        if (m < 3) continue;
        double a2 = 0.0;
        glm::dvec2 cen(0.0);
        for (int k = 0; k < m; ++k) {
          const double cr = cross2(poly[k], poly[(k + 1) % m]);
          a2 += cr;
          cen += (poly[k] + poly[(k + 1) % m]) * cr;
        }
        if (a2 == 0.0) continue;
        cen /= 3.0 * a2;
        const double cover = 0.5 * std::abs(a2);
        if (!(cover > 1e-9)) continue;
        const double a = cover * area3 / area_uv;
        const double w1 = cross2(cen - t[0], t[2] - t[0]) / cross2(t[1] - t[0], t[2] - t[0]);
        const double w2 = cross2(t[1] - t[0], cen - t[0]) / cross2(t[1] - t[0], t[2] - t[0]);
        r.kind[i] = 2;
        r.area[i] += a;
        r.uv_cover[i] += cover;
        r.position[i] += a * (p0 + w1 * (p1 - p0) + w2 * (p2 - p0));
        r.normal[i] += a * nrm;
        if (a > r.largest[i]) {
          r.largest[i] = a;
          r.largest_face[i] = int32_t(f);
        }
        r.overlaps.emplace_back(uint32_t(i), f);
      }
    }
  }
  if (full) {
    for (double cover : r.uv_cover) {
      if (cover > 1.0 + 1e-4) r.overlapping = true;
    }
  }
  return r;
}

// Packing by dropping footprints into a skyline (rows grow downwards from row 0).
struct PackResult {
  bool fits = false;
  int width = 0, height = 0;
  std::vector<glm::ivec2> origin;  // per chart
  std::vector<uint8_t> turned;     // per chart: quarter turns it was packed with
};

// Orientations tried per chart: turned by 0, 90, 180 and 270 degrees.
constexpr int kTurns = 4;

// Turns chart c's parameterisation by `quarters` quarter turns in its plane, each
// (u, v) -> (-v, u). Exact in floating point, so a footprint rasterised turned is reproduced
// exactly, and four quarter turns give the chart back unchanged.
void turnChart(ChartSet& set, size_t c, int quarters) {
  for (uint32_t f : set.charts[c].faces) {
    for (int k = 0; k < 3; ++k) {
      glm::dvec2& p = set.uv[3 * size_t(f) + size_t(k)];
      for (int q = 0; q < (quarters & 3); ++q) p = glm::dvec2(-p.y, p.x);
    }
  }
}

struct Profile {
  int w = 0, h = 0;
  std::vector<int> top;        // per column in [-pad, w + pad): first reserved row (INT_MAX: none)
  std::vector<int> bottom;     // per column in [0, w): last footprint row + 1 (0: none)
  std::vector<uint64_t> rows;  // footprint bits per row (x in bit x), charts up to 64 wide
};

Profile profileOf(const std::vector<uint8_t>& kind, int w, int h, int pad) {
  Profile p;
  p.w = w;
  p.h = h;
  std::vector<int> ftop(size_t(w), std::numeric_limits<int>::max());
  p.bottom.assign(size_t(w), 0);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (kind[size_t(y) * size_t(w) + size_t(x)] == 0) continue;
      ftop[size_t(x)] = std::min(ftop[size_t(x)], y);
      p.bottom[size_t(x)] = y + 1;
    }
  }
  if (w <= 64) {
    p.rows.assign(size_t(h), 0);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        if (kind[size_t(y) * size_t(w) + size_t(x)] != 0) p.rows[size_t(y)] |= uint64_t(1) << x;
      }
    }
  }
  p.top.assign(size_t(w + 2 * pad), std::numeric_limits<int>::max());
  for (int c = -pad; c < w + pad; ++c) {
    int t = std::numeric_limits<int>::max();
    for (int k = std::max(0, c - pad); k <= std::min(w - 1, c + pad); ++k) {
      t = std::min(t, ftop[size_t(k)]);
    }
    p.top[size_t(c + pad)] = t == std::numeric_limits<int>::max() ? t : t - pad;
  }
  return p;
}

PackResult pack(const std::vector<Profile>& profiles, const std::vector<uint32_t>& order, int width,
                int max_height, int pad) {
  PackResult r;
  r.width = width;
  r.origin.assign(profiles.size() / kTurns, glm::ivec2(0));
  r.turned.assign(profiles.size() / kTurns, 0);
  std::vector<int> skyline(size_t(width), 0);
  // Occupancy: placed footprints dilated by the padding, bit x of row y at word x / 64 (one
  // spare word per row so that 64-bit windows can be read anywhere).
  const size_t words = size_t(width) / 64 + 2;
  std::vector<uint64_t> occupied;
  auto window = [&](int y, int x) {
    const uint64_t* row = occupied.data() + size_t(y) * words;
    const size_t w = size_t(x) / 64, b = size_t(x) % 64;
    return b == 0 ? row[w] : (row[w] >> b) | (row[w + 1] << (64 - b));
  };
  int used = 0;
  for (uint32_t c : order) {
    int best_x = -1, best_y = 0, best_turn = 0;
    int64_t best_score = std::numeric_limits<int64_t>::max();
    for (int turn = 0; turn < kTurns; ++turn) {
      const Profile& p = profiles[kTurns * c + size_t(turn)];
      for (int x = 0; x + p.w <= width; ++x) {
        int y = 0;
        for (int k = -pad; k < p.w + pad; ++k) {
          const int col = x + k;
          if (col < 0 || col >= width) continue;
          const int t = p.top[size_t(k + pad)];
          if (t == std::numeric_limits<int>::max()) continue;
          y = std::max(y, skyline[size_t(col)] - t);
        }
        // Lowest bottom first, then least area left unusable under the chart.
        int64_t waste = 0;
        for (int k = 0; k < p.w; ++k) {
          const int t = p.top[size_t(k + pad)];
          if (t != std::numeric_limits<int>::max()) waste += y + t - skyline[size_t(x + k)];
        }
        const int64_t score = int64_t(y + p.h) * (int64_t(1) << 32) + waste;
        if (score < best_score) {
          best_score = score;
          best_x = x;
          best_y = y;
          best_turn = turn;
        }
      }
    }
    if (best_x < 0) return r;
    // Small charts first look for a hole above the skyline (under an overhang, between
    // irregular charts), top-left first, in every orientation. Only positions that put the
    // chart's anchor texel (a footprint texel of its middle row) on a free texel are tried,
    // found 64 at a time from the occupancy bits.
    if (profiles[kTurns * c].w <= 64 && profiles[kTurns * c].h <= 64 && best_y > 0) {
      bool found = false;
      for (int y = 0; y < best_y && !found; ++y) {
        for (int turn = 0; turn < kTurns && !found; ++turn) {
          const Profile& p = profiles[kTurns * c + size_t(turn)];
          if (p.rows.empty() || y + p.h > int(occupied.size() / words)) continue;
          const int ay = p.h / 2;
          if (p.rows[size_t(ay)] == 0) continue;
          const int ax = std::countr_zero(p.rows[size_t(ay)]);
          const uint64_t* row = occupied.data() + size_t(y + ay) * words;
          for (size_t w = 0; w * 64 < size_t(width) && !found; ++w) {
            uint64_t free_bits = ~row[w];
            while (free_bits != 0 && !found) {
              const int bit = std::countr_zero(free_bits);
              free_bits &= free_bits - 1;
              const int x = int(w * 64) + bit - ax;
              if (x < 0 || x + p.w > width) continue;
              bool fits = true;
              for (int row_k = 0; row_k < p.h && fits; ++row_k) {
                fits = (window(y + row_k, x) & p.rows[size_t(row_k)]) == 0;
              }
              if (fits) {
                found = true;
                best_x = x;
                best_y = y;
                best_turn = turn;
              }
            }
          }
        }
      }
    }
    const Profile& p = profiles[kTurns * c + size_t(best_turn)];
    const int bottom = best_y + p.h;
    if (bottom > max_height) return r;
    r.origin[c] = glm::ivec2(best_x, best_y);
    r.turned[c] = uint8_t(best_turn);
    for (int k = 0; k < p.w; ++k) {
      if (p.bottom[size_t(k)] > 0) {
        int& sk = skyline[size_t(best_x + k)];
        sk = std::max(sk, best_y + p.bottom[size_t(k)]);
      }
    }
    used = std::max(used, bottom);
    // Mark the footprint dilated by the padding.
    const size_t need = size_t(bottom + pad + 1) * words;
    if (occupied.size() < need) occupied.resize(need, 0);
    for (int y = 0; y < p.h; ++y) {
      for (int x = 0; x < p.w; ++x) {
        const bool set = p.rows.empty()
                             ? (y >= p.top[size_t(x + pad)] + pad && y < p.bottom[size_t(x)])
                             : ((p.rows[size_t(y)] >> x) & 1) != 0;
        if (!set) continue;
        for (int yy = std::max(0, best_y + y - pad); yy <= best_y + y + pad; ++yy) {
          for (int xx = std::max(0, best_x + x - pad); xx <= std::min(width - 1, best_x + x + pad);
               ++xx) {
            occupied[size_t(yy) * words + size_t(xx) / 64] |= uint64_t(1) << (xx % 64);
          }
        }
      }
    }
  }
  r.height = used;
  r.fits = true;
  return r;
}

int roundUp4(int v) {
  return (v + 3) / 4 * 4;
}

}  // namespace

glm::dvec2 triangleBarycentric(const glm::dvec3& p, const glm::dvec3& p0, const glm::dvec3& p1,
                               const glm::dvec3& p2) {
  // Least squares in the triangle's plane (the normal equations of p - p0 = w1 e1 + w2 e2).
  const glm::dvec3 e1 = p1 - p0, e2 = p2 - p0, r = p - p0;
  const double a11 = glm::dot(e1, e1), a12 = glm::dot(e1, e2), a22 = glm::dot(e2, e2);
  const double det = a11 * a22 - a12 * a12;
  if (!(det > 0.0)) return glm::dvec2(0.0);
  const double b1 = glm::dot(r, e1), b2 = glm::dot(r, e2);
  return glm::dvec2((b1 * a22 - b2 * a12) / det, (a11 * b2 - a12 * b1) / det);
}

glm::dvec3 closestPointOnConvexPolygon(const glm::dvec3& p, const glm::dvec3* poly, int n) {
  // Its plane's normal (Newell), the projection of p, and if that falls outside, the nearest
  // point of the edges.
  glm::dvec3 normal(0.0);
  for (int k = 0; k < n; ++k) normal += glm::cross(poly[k], poly[(k + 1) % n]);
  const double len = glm::length(normal);
  if (!(len > 0.0)) return poly[0];
  normal /= len;
  const glm::dvec3 q = p - normal * glm::dot(normal, p - poly[0]);
  bool inside = true;
  for (int k = 0; k < n && inside; ++k) {
    const glm::dvec3 edge = poly[(k + 1) % n] - poly[k];
    if (glm::dot(glm::cross(edge, q - poly[k]), normal) < -1e-15) inside = false;
  }
  if (inside) return q;
  glm::dvec3 best = poly[0];
  double best_d = std::numeric_limits<double>::max();
  for (int k = 0; k < n; ++k) {
    const glm::dvec3 a = poly[k], ab = poly[(k + 1) % n] - a;
    const double l2 = glm::dot(ab, ab);
    const double u = l2 > 0.0 ? std::clamp(glm::dot(q - a, ab) / l2, 0.0, 1.0) : 0.0;
    const glm::dvec3 c = a + u * ab;
    const double d = glm::length(c - p);
    if (d < best_d) {
      best_d = d;
      best = c;
    }
  }
  return best;
}

uint64_t mortonCode(uint32_t x, uint32_t y) {
  auto spread = [](uint64_t v) {
    v &= 0xffffffffu;
    v = (v | (v << 16)) & 0x0000ffff0000ffffull;
    v = (v | (v << 8)) & 0x00ff00ff00ff00ffull;
    v = (v | (v << 4)) & 0x0f0f0f0f0f0f0f0full;
    v = (v | (v << 2)) & 0x3333333333333333ull;
    v = (v | (v << 1)) & 0x5555555555555555ull;
    return v;
  };
  return spread(x) | (spread(y) << 1);
}

namespace {

// The mesh an atlas is built on: its positions, triangles and the faces (sides) it charts.
struct AtlasMesh {
  std::span<const glm::vec3> positions;
  std::span<const glm::uvec3> triangles;
  std::span<const SurfaceFace> faces;
};

// The charts' footprints packed, and in a full layout each chart rasterised where it was placed.
struct Layout {
  std::vector<ChartRaster> rasters;
  PackResult packing;
};

// Chart sizes first, refusing what cannot fit before rasterising anything.
Status checkChartSizes(const ChartSet& set, double density, const ChartAtlasOptions& options,
                       bool full) {
  uint64_t footprint = 0;
  for (const Chart& chart : set.charts) {
    glm::dvec2 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
    for (uint32_t f : chart.faces) {
      for (int k = 0; k < 3; ++k) {
        lo = glm::min(lo, set.uv[3 * size_t(f) + size_t(k)]);
        hi = glm::max(hi, set.uv[3 * size_t(f) + size_t(k)]);
      }
    }
    const glm::dvec2 ext = (hi - lo) * density + 3.0;
    if (ext.x > double(options.max_resolution) || ext.y > double(options.max_resolution)) {
      return inputError("", "--texel-density",
                        fmt::format("{:.4g} texels per metre makes a chart {:.0f} x {:.0f} texels, "
                                    "more than the largest atlas ({} texels)",
                                    density, ext.x, ext.y, options.max_resolution));
    }
    footprint += uint64_t(ext.x + options.padding) * uint64_t(ext.y + options.padding);
  }
  const uint64_t limit = uint64_t(options.max_resolution) * uint64_t(options.max_resolution);
  if (footprint > limit) {
    return inputError(
        "", "--texel-density",
        fmt::format("{:.4g} texels per metre needs about {} texels, more than the "
                    "largest atlas ({} x {})",
                    density, footprint, options.max_resolution, options.max_resolution));
  }
  return checkMemory(chartAtlasBytes(footprint, 1, footprint) * (full ? 3 : 1),
                     "the lightmap atlas");
}

// Charts whose map overlaps itself (a spiral that the projection folds over) are split, until
// none does.
void splitOverlappingCharts(ChartSet& set, double density, const ChartAtlasOptions& options,
                            const AtlasMesh& mesh) {
  std::vector<uint8_t> checked(set.charts.size(), 0);
  ChartSplitter splitter(mesh.positions, mesh.triangles, mesh.faces, options.charts);
  for (;;) {
    std::vector<uint8_t> overlapping(set.charts.size(), 0);
    parallelRange(set.charts.size(), 1, [&](size_t b, size_t e) {
      for (size_t c = b; c < e; ++c) {
        if (c < checked.size() && checked[c]) continue;
        overlapping[c] =
            rasterise(set, c, density, mesh.positions, mesh.triangles, mesh.faces, true)
                .overlapping;
      }
    });
    checked.assign(set.charts.size(), 1);
    bool split_any = false;
    const size_t count = set.charts.size();
    for (size_t c = 0; c < count; ++c) {
      // An asset's block does not overlap itself (asset_charts.h checks): never split.
      if (!overlapping[c] || set.charts[c].asset_block >= 0) continue;
      if (splitter.split(set, c)) {
        split_any = true;
        checked[c] = 0;
        checked.push_back(0);
      }
    }
    if (!split_any) break;
  }
}

// Footprints in every orientation: chart c turned by `turn` quarter turns is
// profiles[kTurns * c + turn].
std::vector<Profile> footprintProfiles(ChartSet& set, double density, int padding,
                                       const AtlasMesh& mesh) {
  const size_t nc = set.charts.size();
  std::vector<Profile> profiles(kTurns * nc);
  parallelRange(nc, 1, [&](size_t b, size_t e) {
    for (size_t c = b; c < e; ++c) {
      for (int turn = 0; turn < kTurns; ++turn) {
        const ChartRaster r =
            rasterise(set, c, density, mesh.positions, mesh.triangles, mesh.faces, false);
        profiles[kTurns * c + size_t(turn)] = profileOf(r.kind, r.w, r.h, padding);
        turnChart(set, c, 1);  // four quarter turns: back as it was
      }
    }
  });
  return profiles;
}

// The order charts are packed in: largest first (by shorter, then longer side).
std::vector<uint32_t> packingOrder(const std::vector<Profile>& profiles) {
  std::vector<uint32_t> order(profiles.size() / kTurns);
  std::iota(order.begin(), order.end(), 0u);
  auto size = [&](uint32_t c) {
    const Profile& p = profiles[kTurns * c];
    return std::pair<int, int>(std::min(p.w, p.h), std::max(p.w, p.h));
  };
  std::stable_sort(order.begin(), order.end(),
                   [&](uint32_t a, uint32_t b) { return size(a) > size(b); });
  return order;
}

// Near-square: a few widths around the square root of the reserved area, keeping the one with
// the fewest texels.
Expected<PackResult> packNearSquare(const std::vector<Profile>& profiles,
                                    const std::vector<uint32_t>& order, double density,
                                    const ChartAtlasOptions& options) {
  uint64_t reserved = 0;
  int widest = 1;
  for (size_t c = 0; c < profiles.size() / kTurns; ++c) {
    const Profile& p = profiles[kTurns * c];
    reserved += uint64_t(p.w + options.padding) * uint64_t(p.h + options.padding);
    widest = std::max(widest, std::min(p.w, profiles[kTurns * c + 1].w));
  }
  const double side = std::sqrt(double(reserved));
  const double factors[] = {0.9, 1.0, 1.1, 1.25};
  std::vector<PackResult> tries(std::size(factors));
  parallelRange(tries.size(), 1, [&](size_t b, size_t e) {
    for (size_t i = b; i < e; ++i) {
      const int w =
          std::min(options.max_resolution, roundUp4(std::max(widest, int(side * factors[i]))));
      tries[i] = pack(profiles, order, w, options.max_resolution, options.padding);
      tries[i].height = roundUp4(tries[i].height);
    }
  });
  PackResult best;
  bool found = false;
  for (PackResult& p : tries) {
    if (!p.fits) continue;
    if (!found ||
        uint64_t(p.width) * uint64_t(p.height) < uint64_t(best.width) * uint64_t(best.height)) {
      best = std::move(p);
      found = true;
    }
  }
  if (!found) {
    return inputError(
        "", "--texel-density",
        fmt::format("{:.4g} texels per metre does not fit the largest atlas ({} x {})", density,
                    options.max_resolution, options.max_resolution));
  }
  return best;
}

// Turn the charts packed turned, then rasterise them in full where they were placed.
void rasterisePlaced(ChartSet& set, double density, const std::vector<Profile>& profiles,
                     const AtlasMesh& mesh, Layout& out) {
  const size_t nc = set.charts.size();
  for (size_t c = 0; c < nc; ++c) {
    turnChart(set, c, out.packing.turned[c]);
  }
  out.rasters.resize(nc);
  parallelRange(nc, 1, [&](size_t b, size_t e) {
    for (size_t c = b; c < e; ++c) {
      out.rasters[c] = rasterise(set, c, density, mesh.positions, mesh.triangles, mesh.faces, true);
      const Profile& p = profiles[kTurns * c + out.packing.turned[c]];
      PENUMBRA_CHECK(out.rasters[c].w == p.w && out.rasters[c].h == p.h);
    }
  });
}

// Rasterises every chart's footprint at `density` (splitting charts whose parameterisation
// overlaps itself) and packs them. width > 0: that width and at most max_height rows; else a
// near-square atlas.
Expected<Layout> layout(ChartSet& set, double density, int width, int max_height,
                        const ChartAtlasOptions& options, const AtlasMesh& mesh, bool full) {
  PENUMBRA_TRY(checkChartSizes(set, density, options, full));
  if (full) splitOverlappingCharts(set, density, options, mesh);
  const std::vector<Profile> profiles = footprintProfiles(set, density, options.padding, mesh);
  const std::vector<uint32_t> order = packingOrder(profiles);
  Layout out;
  if (width > 0) {
    out.packing = pack(profiles, order, width, max_height, options.padding);
  } else {
    Expected<PackResult> packing = packNearSquare(profiles, order, density, options);
    if (!packing) return packing.error();
    out.packing = std::move(*packing);
  }
  if (full && out.packing.fits) rasterisePlaced(set, density, profiles, mesh, out);
  return out;
}

}  // namespace

int clipTriangleToRect(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c,
                       const glm::dvec2& lo, const glm::dvec2& hi, glm::dvec2* out) {
  // Sutherland-Hodgman against the four sides; the triangle's orientation is kept.
  glm::dvec2 buf[2][8];
  int n = 3;
  buf[0][0] = a;
  buf[0][1] = b;
  buf[0][2] = c;
  int cur = 0;
  for (int side = 0; side < 4 && n > 0; ++side) {
    const int axis = side & 1;
    const bool upper = side >= 2;
    const double bound = upper ? hi[axis] : lo[axis];
    auto inside = [&](const glm::dvec2& p) { return upper ? p[axis] <= bound : p[axis] >= bound; };
    int m = 0;
    for (int k = 0; k < n; ++k) {
      const glm::dvec2& p = buf[cur][k];
      const glm::dvec2& q = buf[cur][(k + 1) % n];
      const bool ip = inside(p), iq = inside(q);
      if (ip) buf[1 - cur][m++] = p;
      if (ip != iq) {
        const double s = (bound - p[axis]) / (q[axis] - p[axis]);
        glm::dvec2 x = p + s * (q - p);
        x[axis] = bound;
        buf[1 - cur][m++] = x;
      }
    }
    n = m;
    cur = 1 - cur;
  }
  for (int k = 0; k < n; ++k) out[k] = buf[cur][k];
  return n;
}

uint64_t chartAtlasBytes(uint64_t width, uint64_t height, uint64_t elements) {
  // Per texel: chart, face, barycentrics, kind, element; per element: texel, chart, area,
  // position, normal and about two face references.
  return width * height * (4 + 4 + 8 + 1 + 4) + elements * (4 + 4 + 8 + 24 + 24 + 12);
}

namespace {

// The options a caller can get wrong, refused before any work.
Status checkAtlasOptions(std::span<const SurfaceFace> faces, const ChartAtlasOptions& options) {
  if (options.padding < 1 || options.padding > 8) {
    return inputError("", "lightmap atlas", "padding must be in [1, 8] texels");
  }
  if (faces.empty()) return inputError("", "", "the lightmap atlas has no faces");
  const bool by_density = options.texel_density > 0.0;
  if (by_density && !std::isfinite(options.texel_density)) {
    return inputError("", "--texel-density", "must be a finite number of texels per metre");
  }
  if (!by_density && (options.resolution < 8 || options.resolution > options.max_resolution)) {
    return inputError(
        "", "--lightmap-size",
        fmt::format("{} is out of range [8, {}]", options.resolution, options.max_resolution));
  }
  return Status();
}

// The largest density whose packing fits resolution x resolution (bisection on a log
// scale, footprints only; then the full rasterisation at the density found).
Expected<double> fittingDensity(ChartSet& charts, const ChartAtlasOptions& options,
                                const AtlasMesh& mesh) {
  double total_area = 0.0;
  for (const Chart& c : charts.charts) total_area += c.area;
  const int res = options.resolution;
  double hi = std::sqrt(double(res) * double(res) / total_area);
  double lo = 0.0;
  for (double d = hi / 2.0; d > hi * 1e-4; d /= 2.0) {
    Expected<Layout> l = layout(charts, d, res, res, options, mesh, false);
    if (l && l->packing.fits) {
      lo = d;
      break;
    }
  }
  if (lo == 0.0) {
    return inputError("", "--lightmap-size",
                      fmt::format("the scene's {} charts do not fit a {} x {} atlas",
                                  charts.charts.size(), res, res));
  }
  for (int it = 0; it < 7; ++it) {
    const double mid = std::sqrt(lo * hi);
    Expected<Layout> l = layout(charts, mid, res, res, options, mesh, false);
    if (l && l->packing.fits) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  return lo;
}

// The full layout at `density` texels per metre, or, for a fixed resolution, at the largest
// density that fits it (`density` is set to the one used).
Expected<Layout> atlasLayout(ChartSet& charts, double& density, const ChartAtlasOptions& options,
                             const AtlasMesh& mesh) {
  if (options.texel_density > 0.0) {
    return layout(charts, density, 0, options.max_resolution, options, mesh, true);
  }
  const Expected<double> fit = fittingDensity(charts, options, mesh);
  if (!fit) return fit.error();
  // The full layout may split charts whose maps overlap themselves and pack differently:
  // a little less density until it fits.
  const int res = options.resolution;
  density = *fit;
  for (int attempt = 0;; ++attempt) {
    Expected<Layout> l = layout(charts, density, res, res, options, mesh, true);
    if (!l) return l.error();
    if (l->packing.fits) {
      l->packing.height = res;
      return l;
    }
    if (attempt == 20) {
      return inputError("", "--lightmap-size",
                        fmt::format("the scene's charts do not fit a {} x {} atlas", res, res));
    }
    density *= 0.97;
  }
}

// Whether the atlas's texels and elements (one per covered texel) fit in memory.
Status checkAtlasMemory(const ChartAtlas& atlas, const std::vector<ChartRaster>& rasters) {
  uint64_t elements = 0;
  for (const ChartRaster& r : rasters) {
    for (uint8_t k : r.kind) elements += k == 2;
  }
  return checkMemory(chartAtlasBytes(uint64_t(atlas.width), uint64_t(atlas.height), elements),
                     fmt::format("a {} x {} lightmap atlas", atlas.width, atlas.height));
}

// Chart c's texels at its place in the atlas, and an element per covered texel; r is released.
void placeChart(ChartAtlas& atlas, size_t c, ChartRaster& r, const glm::ivec2& origin) {
  AtlasChartPlacement& pl = atlas.placement[c];
  pl.origin = origin;
  pl.size = glm::ivec2(r.w, r.h);
  pl.first_element = uint32_t(atlas.element_texel.size());
  std::sort(r.overlaps.begin(), r.overlaps.end());
  // Covered texels in Morton (Z) order of their chart-local coordinates, so that every
  // 2^l x 2^l block of the chart holds a contiguous range of elements (the hierarchy's
  // clusters, geometry/surface_hierarchy.h).
  std::vector<std::pair<uint64_t, uint32_t>> covered;
  for (int y = 0; y < r.h; ++y) {
    for (int x = 0; x < r.w; ++x) {
      const size_t i = size_t(y) * size_t(r.w) + size_t(x);
      if (r.kind[i] == 0) continue;
      const size_t t = atlas.texelIndex(pl.origin.x + x, pl.origin.y + y);
      PENUMBRA_CHECK_MSG(atlas.texel_kind[t] == AtlasTexelKind::kEmpty,
                         "footprints overlap at texel {}", t);
      atlas.texel_chart[t] = int32_t(c);
      atlas.texel_face[t] = r.face[i];
      atlas.texel_barycentric[t] = r.barycentric[i];
      atlas.texel_kind[t] = r.kind[i] == 1 ? AtlasTexelKind::kBorder : AtlasTexelKind::kInside;
      if (r.kind[i] == 2) covered.emplace_back(mortonCode(uint32_t(x), uint32_t(y)), uint32_t(i));
    }
  }
  std::sort(covered.begin(), covered.end());
  for (const auto& [code, i] : covered) {
    const int x = int(i % uint32_t(r.w)), y = int(i / uint32_t(r.w));
    const size_t t = atlas.texelIndex(pl.origin.x + x, pl.origin.y + y);
    atlas.texel_element[t] = int32_t(atlas.element_texel.size());
    atlas.element_texel.push_back(uint32_t(t));
    atlas.element_chart.push_back(uint32_t(c));
    atlas.element_area.push_back(r.area[i]);
    // The centroid of the pieces for now (moved onto the surface below).
    atlas.element_position.push_back(r.position[i] / r.area[i]);
    atlas.element_face.push_back(uint32_t(r.largest_face[i]));
    const double len = glm::length(r.normal[i]);
    atlas.element_normal.push_back(len > 0.0 ? r.normal[i] / len : atlas.charts.charts[c].normal);
    auto ov = std::lower_bound(r.overlaps.begin(), r.overlaps.end(),
                               std::pair<uint32_t, uint32_t>(i, 0u));
    for (; ov != r.overlaps.end() && ov->first == i; ++ov) {
      atlas.element_faces.push_back(ov->second);
    }
    atlas.element_face_first.push_back(uint32_t(atlas.element_faces.size()));
  }
  pl.element_count = uint32_t(atlas.element_texel.size()) - pl.first_element;
  r = ChartRaster();  // release as we go
}

// Texels and elements.
void placeCharts(ChartAtlas& atlas, Layout& lay) {
  const uint64_t texels = uint64_t(atlas.width) * uint64_t(atlas.height);
  const size_t nc = atlas.charts.charts.size();
  atlas.texel_chart.assign(texels, -1);
  atlas.texel_face.assign(texels, -1);
  atlas.texel_barycentric.assign(texels, glm::vec2(0.0f));
  atlas.texel_kind.assign(texels, AtlasTexelKind::kEmpty);
  atlas.texel_element.assign(texels, -1);
  atlas.placement.resize(nc);
  atlas.element_face_first.push_back(0);
  for (size_t c = 0; c < nc; ++c) placeChart(atlas, c, lay.rasters[c], lay.packing.origin[c]);
}

// Corner coordinates in texels and UVs.
void placeCorners(ChartAtlas& atlas, double density) {
  const size_t nf = atlas.faces.size();
  atlas.corner_texel.assign(3 * nf, glm::dvec2(0.0));
  atlas.uvs.assign(3 * nf, glm::vec2(0.0f));
  // The local frame needs each chart's UV minimum; recomputed here (cheap).
  std::vector<glm::dvec2> chart_min(atlas.charts.charts.size(),
                                    glm::dvec2(std::numeric_limits<double>::max()));
  for (size_t f = 0; f < nf; ++f) {
    const int32_t c = atlas.charts.face_chart[f];
    if (c < 0) continue;
    for (int k = 0; k < 3; ++k) {
      chart_min[size_t(c)] = glm::min(chart_min[size_t(c)], atlas.charts.uv[3 * f + size_t(k)]);
    }
  }
  for (size_t f = 0; f < nf; ++f) {
    const int32_t c = atlas.charts.face_chart[f];
    if (c < 0) continue;
    for (int k = 0; k < 3; ++k) {
      const size_t i = 3 * f + size_t(k);
      atlas.corner_texel[i] = localTexel(atlas.charts.uv[i], chart_min[size_t(c)], density) +
                              glm::dvec2(atlas.placement[size_t(c)].origin);
      atlas.uvs[i] = glm::vec2(atlas.corner_texel[i].x / double(atlas.width),
                               atlas.corner_texel[i].y / double(atlas.height));
    }
  }
}

// Element points on the surface: the point of the element's pieces nearest their centroid.
// Where a chart bends inside a texel (a scan's charts bend in every texel) the centroid lies
// off the surface, inside a convex solid, where shadow rays would start.
void moveElementsOntoSurface(ChartAtlas& atlas, std::span<const glm::vec3> positions,
                             std::span<const glm::uvec3> triangles) {
  atlas.element_barycentric.assign(atlas.elementCount(), glm::vec2(0.0f));
  parallelRange(atlas.elementCount(), 256, [&](size_t b, size_t e_end) {
    for (size_t e = b; e < e_end; ++e) {
      const glm::dvec3 centroid = atlas.element_position[e];
      double best = std::numeric_limits<double>::max();
      glm::dvec3 point = centroid;
      uint32_t face = atlas.element_face[e];
      const glm::ivec2 t = atlas.texelOf(e);
      atlas.forEachPiece(
          t, t, atlas.elementFaces(e), positions, triangles,
          [&](uint32_t f, const std::array<glm::dvec3, 8>& poly, int n, double area) {
            if (!(area > 0.0)) return;
            const glm::dvec3 q = closestPointOnConvexPolygon(centroid, poly.data(), n);
            const double d = glm::length(q - centroid);
            if (d < best) {
              best = d;
              point = q;
              face = f;
            }
          });
      atlas.element_position[e] = point;
      atlas.element_face[e] = face;
      const glm::uvec3 tri = triangles[atlas.faces[face].triangle];
      atlas.element_barycentric[e] = glm::vec2(
          triangleBarycentric(point, glm::dvec3(positions[tri.x]), glm::dvec3(positions[tri.y]),
                              glm::dvec3(positions[tri.z])));
    }
  });
}

// Dilation into the padding: empty texels next to a footprint copy a neighbour's chart, face
// and barycentrics (4-neighbours first, then diagonals, in a fixed order).
void dilateIntoPadding(ChartAtlas& atlas, int padding) {
  std::vector<AtlasTexelKind> kinds;
  for (int round = 0; round < padding; ++round) {
    kinds = atlas.texel_kind;
    parallelRange(size_t(atlas.height), 16, [&](size_t yb, size_t ye) {
      static constexpr int kDx[8] = {-1, 1, 0, 0, -1, 1, -1, 1};
      static constexpr int kDy[8] = {0, 0, -1, 1, -1, -1, 1, 1};
      for (size_t y = yb; y < ye; ++y) {
        for (int x = 0; x < atlas.width; ++x) {
          const size_t t = atlas.texelIndex(x, int(y));
          if (kinds[t] != AtlasTexelKind::kEmpty) continue;
          for (int k = 0; k < 8; ++k) {
            const int nx = x + kDx[k], ny = int(y) + kDy[k];
            if (nx < 0 || ny < 0 || nx >= atlas.width || ny >= atlas.height) continue;
            const size_t s = atlas.texelIndex(nx, ny);
            if (kinds[s] == AtlasTexelKind::kEmpty) continue;
            atlas.texel_kind[t] = AtlasTexelKind::kDilated;
            atlas.texel_chart[t] = atlas.texel_chart[s];
            atlas.texel_face[t] = atlas.texel_face[s];
            atlas.texel_barycentric[t] = atlas.texel_barycentric[s];
            break;
          }
        }
      }
    });
  }
}

}  // namespace

Expected<ChartAtlas> buildChartAtlas(std::span<const glm::vec3> positions,
                                     std::span<const glm::uvec3> triangles,
                                     std::span<const uint32_t> material_ids,
                                     std::span<const SurfaceFace> faces,
                                     const ChartAtlasOptions& options,
                                     const AssetLightmapUvs* asset) {
  PENUMBRA_TRY(checkAtlasOptions(faces, options));
  ChartAtlas atlas;
  atlas.faces.assign(faces.begin(), faces.end());
  atlas.padding = options.padding;
  std::vector<int32_t> face_island;
  if (asset) {
    Expected<ChartSet> charts = chartsWithAssetUvs(positions, triangles, material_ids, faces,
                                                   options.charts, *asset, face_island);
    if (!charts) return charts.error();
    atlas.charts = std::move(*charts);
  } else {
    atlas.charts = buildCharts(positions, triangles, material_ids, faces, options.charts);
  }
  if (atlas.charts.charts.empty()) {
    return inputError("", "", "the lightmap atlas has only degenerate faces");
  }

  double density = options.texel_density;
  Expected<Layout> lay = atlasLayout(atlas.charts, density, options, {positions, triangles, faces});
  if (!lay) return lay.error();
  atlas.texel_density = density;
  atlas.width = lay->packing.width;
  atlas.height = std::max(4, lay->packing.height);
  PENUMBRA_TRY(checkAtlasMemory(atlas, lay->rasters));

  placeCharts(atlas, *lay);
  placeCorners(atlas, density);
  moveElementsOntoSurface(atlas, positions, triangles);
  dilateIntoPadding(atlas, options.padding);
  if (asset) splitAssetBlocks(atlas, face_island);
  return atlas;
}

std::vector<SurfaceFace> surfaceFaces(const Scene& scene, const FlatTriangles& flat) {
  std::vector<SurfaceFace> faces;
  faces.reserve(2 * flat.triangles.size());
  for (uint32_t t = 0; t < flat.triangles.size(); ++t) {
    faces.push_back({t, false});
    if (scene.materials[flat.material_ids[t]].two_sided) faces.push_back({t, true});
  }
  return faces;
}

ChartGapPlan planChartGaps(const ChartAtlas& a, std::vector<uint8_t> known) {
  PENUMBRA_CHECK(known.size() == a.texel_kind.size());
  ChartGapPlan plan;
  plan.first.push_back(0);
  for (int round = 0; round < 64; ++round) {
    const size_t round_start = plan.texel.size();
    for (int y = 0; y < a.height; ++y) {
      for (int x = 0; x < a.width; ++x) {
        const size_t i = a.texelIndex(x, y);
        if (known[i] || a.texel_kind[i] == AtlasTexelKind::kEmpty) continue;
        const size_t before = plan.source.size();
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            const int xx = x + dx, yy = y + dy;
            if (xx < 0 || yy < 0 || xx >= a.width || yy >= a.height) continue;
            const size_t j = a.texelIndex(xx, yy);
            if (!known[j] || a.texel_chart[j] != a.texel_chart[i]) continue;
            plan.source.push_back(uint32_t(j));
          }
        }
        if (plan.source.size() == before) continue;
        plan.texel.push_back(uint32_t(i));
        plan.first.push_back(uint32_t(plan.source.size()));
      }
    }
    if (plan.texel.size() == round_start) break;
    // Texels filled in this round are sources from the next one on.
    for (size_t k = round_start; k < plan.texel.size(); ++k) known[plan.texel[k]] = 1;
  }
  return plan;
}

void applyChartGaps(const ChartGapPlan& plan, Image& img) {
  for (size_t k = 0; k < plan.texel.size(); ++k) {
    glm::vec3 sum(0.0f);
    for (uint32_t s = plan.first[k]; s < plan.first[k + 1]; ++s) sum += img.pixels[plan.source[s]];
    img.pixels[plan.texel[k]] = sum / float(plan.first[k + 1] - plan.first[k]);
  }
}

void fillChartGaps(const ChartAtlas& a, Image& img, std::vector<uint8_t>& known) {
  PENUMBRA_CHECK(img.width == a.width && img.height == a.height);
  const ChartGapPlan plan = planChartGaps(a, known);
  applyChartGaps(plan, img);
  for (uint32_t t : plan.texel) known[t] = 1;
}

double faceArea(const Scene& scene) {
  const FlatTriangles flat = flattenScene(scene);
  double area = 0.0;
  for (size_t t = 0; t < flat.triangles.size(); ++t) {
    const glm::uvec3 tri = flat.triangles[t];
    const double a =
        0.5 * glm::length(glm::cross(glm::dvec3(flat.positions[tri.y] - flat.positions[tri.x]),
                                     glm::dvec3(flat.positions[tri.z] - flat.positions[tri.x])));
    area += scene.materials[flat.material_ids[t]].two_sided ? 2.0 * a : a;
  }
  return area;
}

int ChartAtlas::elementPieces(size_t e, std::span<const glm::vec3> positions,
                              std::span<const glm::uvec3> triangles,
                              std::vector<std::array<glm::dvec3, 8>>& polygons,
                              std::vector<int>& counts) const {
  polygons.clear();
  counts.clear();
  const glm::ivec2 t = texelOf(e);
  forEachPiece(t, t, elementFaces(e), positions, triangles,
               [&](uint32_t, const std::array<glm::dvec3, 8>& corners, int n, double) {
                 polygons.push_back(corners);
                 counts.push_back(n);
               });
  return int(polygons.size());
}

ChartAtlasQuality measureChartAtlas(const ChartAtlas& atlas, std::span<const glm::vec3> positions,
                                    std::span<const glm::uvec3> triangles) {
  ChartAtlasQuality q;
  q.charts = atlas.chartCount();
  q.elements = atlas.elementCount();
  q.utilisation = double(q.elements) / (double(atlas.width) * double(atlas.height));
  double weighted = 0.0, area = 0.0;
  for (size_t f = 0; f < atlas.faces.size(); ++f) {
    if (atlas.charts.face_chart[f] < 0) continue;
    const glm::uvec3 tri = triangles[atlas.faces[f].triangle];
    const double a = 0.5 * glm::length(glm::cross(glm::dvec3(positions[tri.y] - positions[tri.x]),
                                                  glm::dvec3(positions[tri.z] - positions[tri.x])));
    q.max_stretch = std::max(q.max_stretch, atlas.charts.stretch[f]);
    weighted += a * atlas.charts.stretch[f];
    area += a;
  }
  q.mean_stretch = area > 0.0 ? weighted / area : 1.0;
  for (const Chart& c : atlas.charts.charts) {
    q.planar_charts += c.planar;
    q.conformal_charts += c.conformal;
  }
  return q;
}

}  // namespace penumbra
