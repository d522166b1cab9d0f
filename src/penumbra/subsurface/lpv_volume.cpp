#include "penumbra/subsurface/lpv_volume.h"

#include "penumbra/core/parallel.h"
#include "penumbra/geometry/triangle_box.h"
#include "penumbra/scene/heterogeneous_media.h"
#include "penumbra/subsurface/lpv_sh.h"

#include <glm/mat4x4.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>

namespace penumbra {

namespace {

// Whether the 2-D point p lies in the triangle (a, b, c) (counter-clockwise), with the
// top-left rule on its edges so that a point on an edge two triangles share counts once.
bool insideTopLeft(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c,
                   const glm::dvec2& p) {
  const glm::dvec2 v[3] = {a, b, c};
  for (int i = 0; i < 3; ++i) {
    const glm::dvec2 e0 = v[i], e1 = v[(i + 1) % 3];
    const double w = (e1.x - e0.x) * (p.y - e0.y) - (e1.y - e0.y) * (p.x - e0.x);
    if (w < 0.0) return false;
    if (w == 0.0) {
      // Counter-clockwise: a top edge runs in -x at constant y, a left edge has y decreasing.
      const glm::dvec2 d = e1 - e0;
      const bool top_left = (d.y == 0.0 && d.x < 0.0) || d.y < 0.0;
      if (!top_left) return false;
    }
  }
  return true;
}

}  // namespace

LpvGrid LpvGrid::around(const Bounds3& bounds, int resolution) {
  LpvGrid g;
  const glm::dvec3 lo(bounds.lo), hi(bounds.hi);
  const glm::dvec3 extent = glm::max(hi - lo, glm::dvec3(1e-9));
  const int inner = std::max(resolution - 2, 1);
  g.cell = std::max({extent.x, extent.y, extent.z}) / double(inner);
  for (int a = 0; a < 3; ++a) {
    g.size[a] = std::max(1, int(std::ceil(extent[a] / g.cell - 1e-9))) + 2;
  }
  g.origin = 0.5 * (lo + hi) - 0.5 * glm::dvec3(g.size) * g.cell;
  return g;
}

glm::ivec3 LpvGrid::cellOf(const glm::dvec3& p) const {
  const glm::dvec3 f = glm::floor((p - origin) / cell);
  return glm::clamp(glm::ivec3(f), glm::ivec3(0), size - 1);
}

std::vector<LpvCell> lpvVoxelise(const LpvGrid& grid, std::span<const glm::vec3> positions,
                                 std::span<const glm::uvec3> triangles) {
  const size_t n = grid.cellCount();
  std::vector<LpvCell> cells(n, LpvCell::kOutside);
  // Inside: crossings of the lines through the cell centres along +x, per (y, z) row.
  const size_t rows = size_t(grid.size.y) * size_t(grid.size.z);
  std::vector<std::vector<double>> crossings(rows);
  for (const glm::uvec3& t : triangles) {
    const glm::dvec3 p[3] = {glm::dvec3(positions[t.x]), glm::dvec3(positions[t.y]),
                             glm::dvec3(positions[t.z])};
    // The triangle in the (y, z) plane, counter-clockwise.
    glm::dvec2 q[3] = {{p[0].y, p[0].z}, {p[1].y, p[1].z}, {p[2].y, p[2].z}};
    const double area2 =
        (q[1].x - q[0].x) * (q[2].y - q[0].y) - (q[1].y - q[0].y) * (q[2].x - q[0].x);
    if (area2 == 0.0) continue;  // edge-on to the rows
    glm::dvec3 r[3] = {p[0], p[1], p[2]};
    if (area2 < 0.0) {
      std::swap(q[1], q[2]);
      std::swap(r[1], r[2]);
    }
    const double ylo = std::min({q[0].x, q[1].x, q[2].x}), yhi = std::max({q[0].x, q[1].x, q[2].x});
    const double zlo = std::min({q[0].y, q[1].y, q[2].y}), zhi = std::max({q[0].y, q[1].y, q[2].y});
    const int y0 = std::max(0, int(std::ceil((ylo - grid.origin.y) / grid.cell - 0.5)));
    const int y1 =
        std::min(grid.size.y - 1, int(std::floor((yhi - grid.origin.y) / grid.cell - 0.5)));
    const int z0 = std::max(0, int(std::ceil((zlo - grid.origin.z) / grid.cell - 0.5)));
    const int z1 =
        std::min(grid.size.z - 1, int(std::floor((zhi - grid.origin.z) / grid.cell - 0.5)));
    const glm::dvec3 normal = glm::cross(r[1] - r[0], r[2] - r[0]);
    for (int z = z0; z <= z1; ++z) {
      for (int y = y0; y <= y1; ++y) {
        const glm::dvec3 c = grid.centre(glm::ivec3(0, y, z));
        if (!insideTopLeft(q[0], q[1], q[2], glm::dvec2(c.y, c.z))) continue;
        // The plane's x at (y, z): normal . (x - r0) = 0.
        const double x =
            r[0].x - (normal.y * (c.y - r[0].y) + normal.z * (c.z - r[0].z)) / normal.x;
        crossings[size_t(z) * size_t(grid.size.y) + size_t(y)].push_back(x);
      }
    }
  }
  parallelRange(rows, 64, [&](size_t begin, size_t end) {
    for (size_t row = begin; row < end; ++row) {
      std::vector<double>& xs = crossings[row];
      std::sort(xs.begin(), xs.end());
      const int y = int(row % size_t(grid.size.y)), z = int(row / size_t(grid.size.y));
      size_t passed = 0;
      for (int x = 0; x < grid.size.x; ++x) {
        const double cx = grid.centre(glm::ivec3(x, y, z)).x;
        while (passed < xs.size() && xs[passed] < cx) ++passed;
        if (passed % 2 == 1) cells[grid.index(glm::ivec3(x, y, z))] = LpvCell::kInside;
      }
    }
  });
  // Boundary: cells a triangle overlaps.
  const glm::dvec3 half(0.5 * grid.cell);
  parallelRange(triangles.size(), 256, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const glm::uvec3 t = triangles[i];
      const glm::dvec3 a(positions[t.x]), b(positions[t.y]), c(positions[t.z]);
      const glm::ivec3 lo = grid.cellOf(glm::min(glm::min(a, b), c));
      const glm::ivec3 hi = grid.cellOf(glm::max(glm::max(a, b), c));
      for (int z = lo.z; z <= hi.z; ++z) {
        for (int y = lo.y; y <= hi.y; ++y) {
          for (int x = lo.x; x <= hi.x; ++x) {
            const glm::ivec3 cell(x, y, z);
            if (!triangleOverlapsBox(grid.centre(cell), half, a, b, c)) continue;
            std::atomic_ref<LpvCell>(cells[grid.index(cell)])
                .store(LpvCell::kBoundary, std::memory_order_relaxed);
          }
        }
      }
    }
  });
  // The outer layer of cells stays outside (a triangle can only touch it, at the bounds' faces):
  // every cell of the object then has its six neighbours in the grid.
  for (int z = 0; z < grid.size.z; ++z) {
    for (int y = 0; y < grid.size.y; ++y) {
      for (int x = 0; x < grid.size.x; ++x) {
        if (x == 0 || y == 0 || z == 0 || x == grid.size.x - 1 || y == grid.size.y - 1 ||
            z == grid.size.z - 1) {
          cells[grid.index(glm::ivec3(x, y, z))] = LpvCell::kOutside;
        }
      }
    }
  }
  return cells;
}

LpvMedium lpvHomogeneousMedium(const LpvGrid& grid, const Subsurface& medium) {
  const size_t n = grid.cellCount();
  LpvMedium m;
  const double g = std::clamp(medium.g, -0.999, 0.999);
  const glm::dvec3 sigma_s = medium.sigma_s_prime / (1.0 - g);
  const glm::vec3 s(1.0 - glm::exp(-sigma_s * grid.cell));
  m.extinction.assign(n, glm::vec3(medium.sigma_a));
  m.scattering.assign(n, s);
  m.g.assign(n, float(g));
  return m;
}

LpvMedium lpvMedium(const LpvGrid& grid, const Subsurface& medium, const Bounds3& box) {
  if (!medium.grid && medium.pattern.empty()) return lpvHomogeneousMedium(grid, medium);
  const size_t n = grid.cellCount();
  LpvMedium m;
  m.extinction.resize(n);
  m.scattering.resize(n);
  m.g.resize(n);
  const glm::dvec3 lo(box.lo), extent = glm::max(glm::dvec3(box.hi) - lo, glm::dvec3(1e-12));
  parallelRange(size_t(grid.size.z), 1, [&](size_t z0, size_t z1) {
    for (int z = int(z0); z < int(z1); ++z) {
      for (int y = 0; y < grid.size.y; ++y) {
        for (int x = 0; x < grid.size.x; ++x) {
          const glm::ivec3 c(x, y, z);
          const glm::dvec3 u = glm::clamp((grid.centre(c) - lo) / extent, 0.0, 1.0);
          const MediumSample s = mediumAt(medium, u);
          const double g = std::clamp(s.g, -0.999, 0.999);
          const size_t i = grid.index(c);
          m.extinction[i] = glm::vec3(s.sigma_a);
          m.scattering[i] = glm::vec3(1.0 - glm::exp(-s.sigma_s_prime / (1.0 - g) * grid.cell));
          m.g[i] = float(g);
        }
      }
    }
  });
  return m;
}

void LpvField::resize(size_t cells) {
  for (std::vector<glm::vec4>& v : c) v.assign(cells, glm::vec4(0.0f));
}

void LpvField::clear() {
  for (std::vector<glm::vec4>& v : c) std::fill(v.begin(), v.end(), glm::vec4(0.0f));
}

glm::dvec3 LpvField::flux() const {
  glm::dvec3 sum(0.0);
  for (int ch = 0; ch < 3; ++ch) {
    for (const glm::vec4& v : c[size_t(ch)]) sum[ch] += lpvFlux(glm::dvec4(v));
  }
  return sum;
}

LpvTransfer lpvTransfer(const LpvGrid& grid, std::span<const LpvCell> cells,
                        const LpvMedium& medium) {
  LpvTransfer t;
  // The object's cells, but not the grid's outer layer (whose neighbours would leave the grid).
  for (int z = 1; z + 1 < grid.size.z; ++z) {
    for (int y = 1; y + 1 < grid.size.y; ++y) {
      for (int x = 1; x + 1 < grid.size.x; ++x) {
        const size_t i = grid.index(glm::ivec3(x, y, z));
        if (cells[i] != LpvCell::kOutside) t.cells.push_back(uint32_t(i));
      }
    }
  }
  for (std::vector<glm::vec4>& v : t.scale) v.assign(cells.size(), glm::vec4(0.0f));
  parallelRange(t.cells.size(), 4096, [&](size_t begin, size_t end) {
    for (size_t k = begin; k < end; ++k) {
      const size_t i = t.cells[k];
      for (int ch = 0; ch < 3; ++ch) {
        const double att = std::exp(-double(medium.extinction[i][ch]) * grid.cell);
        const double s = medium.scattering[i][ch];
        const double band1 = att * ((1.0 - s) + s * double(medium.g[i]));
        t.scale[size_t(ch)][i] = glm::vec4(float(att), float(band1), float(band1), float(band1));
      }
    }
  });
  return t;
}

void lpvPropagate(const LpvGrid& grid, const LpvTransfer& transfer, const LpvField& from,
                  LpvField& to, LpvField& sent) {
  // The matrices' six non-zero entries (lpv_sh.h): for light travelling along axis a with sign
  // sigma, band 0 takes m00 c0 + sigma m0a c_a, the band-1 coefficient along a takes
  // sigma ma0 c0 + maa c_a, the two across it mbb times their own. The two neighbours along an
  // axis are summed together: their sigma differ.
  static const struct Entries {
    float m00, m0a, ma0, maa, mbb;
  } e = [] {
    const glm::dmat4& m = lpvPropagationMatrices()[0];  // +x: a is y11 (index 3)
    return Entries{float(m[0][0]), float(m[3][0]), float(m[0][3]), float(m[3][3]), float(m[1][1])};
  }();
  const size_t n = grid.cellCount();
  if (sent.c[0].size() != n) sent.resize(n);
  // What each object cell sends (outside cells stay zero: they send nothing).
  parallelRange(transfer.cells.size(), 2048, [&](size_t begin, size_t end) {
    for (size_t k = begin; k < end; ++k) {
      const uint32_t i = transfer.cells[k];
      for (size_t ch = 0; ch < 3; ++ch) sent.c[ch][i] = from.c[ch][i] * transfer.scale[ch][i];
    }
  });
  const size_t sx = 1, sy = size_t(grid.size.x), sz = size_t(grid.size.x) * size_t(grid.size.y);
  parallelRange(transfer.cells.size(), 512, [&](size_t begin, size_t end) {
    for (size_t k = begin; k < end; ++k) {
      // Object cells are never on the grid's outer layer (lpvVoxelise): all six neighbours exist.
      const size_t d = transfer.cells[k];
      for (size_t ch = 0; ch < 3; ++ch) {
        const glm::vec4* c = sent.c[ch].data();
        // x: the coupled coefficient is y11 (w); y: y1-1 (y); z: y10 (z). Lower neighbour's
        // light travels +axis (sigma = +1), the upper's -axis.
        const glm::vec4 xl = c[d - sx], xu = c[d + sx];
        const glm::vec4 yl = c[d - sy], yu = c[d + sy];
        const glm::vec4 zl = c[d - sz], zu = c[d + sz];
        const glm::vec4 xs = xl + xu, ys = yl + yu, zs = zl + zu;
        const glm::vec4 xd = xl - xu, yd = yl - yu, zd = zl - zu;
        glm::vec4 out;
        out.x = e.m00 * (xs.x + ys.x + zs.x) + e.m0a * (xd.w + yd.y + zd.z);
        out.y = e.ma0 * yd.x + e.maa * ys.y + e.mbb * (xs.y + zs.y);
        out.z = e.ma0 * zd.x + e.maa * zs.z + e.mbb * (xs.z + ys.z);
        out.w = e.ma0 * xd.x + e.maa * xs.w + e.mbb * (ys.w + zs.w);
        to.c[ch][d] = out;
      }
    }
  });
}

}  // namespace penumbra
