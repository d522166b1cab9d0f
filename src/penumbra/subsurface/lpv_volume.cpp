#include "penumbra/subsurface/lpv_volume.h"

#include "penumbra/core/parallel.h"
#include "penumbra/geometry/triangle_box.h"
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
  for (size_t i = 0; i < cells.size(); ++i) {
    if (cells[i] != LpvCell::kOutside) t.cells.push_back(uint32_t(i));
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

void lpvPropagate(const LpvGrid& grid, std::span<const LpvCell> cells, const LpvTransfer& transfer,
                  const LpvField& from, LpvField& to) {
  // The matrices' six non-zero entries (lpv_sh.h): for light travelling along axis a with sign
  // sigma, band 0 takes m00 c0 + sigma m0a c_a, the band-1 coefficient along a takes
  // sigma ma0 c0 + maa c_a, the two across it mbb times their own.
  static const struct Entries {
    float m00, m0a, ma0, maa, mbb;
  } e = [] {
    const glm::dmat4& m = lpvPropagationMatrices()[0];  // +x: a is y11 (index 3)
    return Entries{float(m[0][0]), float(m[3][0]), float(m[0][3]), float(m[3][3]), float(m[1][1])};
  }();
  // The SH index coupled to each axis: y11 ~ x, y1-1 ~ y, y10 ~ z.
  constexpr int kCoupled[3] = {3, 1, 2};
  const std::array<int64_t, 3> stride = {1, int64_t(grid.size.x),
                                         int64_t(grid.size.x) * int64_t(grid.size.y)};
  parallelRange(transfer.cells.size(), 512, [&](size_t begin, size_t end) {
    for (size_t k = begin; k < end; ++k) {
      const uint32_t d = transfer.cells[k];
      const int x = int(d % uint32_t(grid.size.x));
      const int y = int((d / uint32_t(grid.size.x)) % uint32_t(grid.size.y));
      const int z = int(d / (uint32_t(grid.size.x) * uint32_t(grid.size.y)));
      const int coord[3] = {x, y, z};
      glm::vec4 sum[3] = {glm::vec4(0.0f), glm::vec4(0.0f), glm::vec4(0.0f)};
      for (int axis = 0; axis < 3; ++axis) {
        const int a = kCoupled[axis];
        for (int side = 0; side < 2; ++side) {
          // Light travelling +axis comes from the cell at -axis (side 0), and the other way.
          const float sigma = side == 0 ? 1.0f : -1.0f;
          const int sc = coord[axis] + (side == 0 ? -1 : 1);
          if (sc < 0 || sc >= grid.size[axis]) continue;
          const size_t s =
              size_t(int64_t(d) + (side == 0 ? -stride[size_t(axis)] : stride[size_t(axis)]));
          if (cells[s] == LpvCell::kOutside) continue;
          for (int ch = 0; ch < 3; ++ch) {
            const glm::vec4 c = from.c[size_t(ch)][s] * transfer.scale[size_t(ch)][s];
            glm::vec4 out(0.0f);
            out = c * e.mbb;
            out.x = e.m00 * c.x + sigma * e.m0a * c[a];
            out[a] = sigma * e.ma0 * c.x + e.maa * c[a];
            sum[ch] += out;
          }
        }
      }
      for (int ch = 0; ch < 3; ++ch) to.c[size_t(ch)][d] = sum[ch];
    }
  });
}

}  // namespace penumbra
