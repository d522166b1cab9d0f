// Subsurface light propagation volumes (Børlum et al. 2011), the grid's parts: the propagation
// matrices derived from their integrals equal the values printed in sec. 4; the clamped-cosine
// lobe and the area-light estimate (eq. 5-7) are what their integrals say; a propagation step
// conserves flux when nothing absorbs or leaves, and absorbs exp(-sigma dx) per step when the
// medium does; the voxelisation finds a sphere's inside and boundary cells.
#include "penumbra/subsurface/lpv_sh.h"
#include "penumbra/subsurface/lpv_volume.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

namespace penumbra {
namespace {

// Row i, column j of a glm (column-major) matrix.
double at(const glm::dmat4& m, int i, int j) {
  return m[j][i];
}

// Sec. 4: for source cells at d -/+ x (light travelling +x / -x) the matrix
//   ( 0.167  0      0      +-0.240 )
//   ( 0      0.070  0      0       )
//   ( 0      0      0.070  0       )
//   ( +-0.037 0     0      0.062   )
// and for y and z the same with the fourth row and column swapped with the second and third.
TEST(Lpv, PropagationMatricesAreThePapers) {
  const std::array<glm::dmat4, 6>& m = lpvPropagationMatrices();
  // The SH index coupled to each axis: y11 ~ x (3), y1-1 ~ y (1), y10 ~ z (2).
  const int coupled[3] = {3, 1, 2};
  for (size_t k = 0; k < 6; ++k) {
    const int axis = int(k / 2), a = coupled[axis];
    const double sign = k % 2 == 0 ? 1.0 : -1.0;
    double want[4][4] = {};
    want[0][0] = 0.167;
    want[0][a] = sign * 0.240;
    want[a][0] = sign * 0.037;
    want[a][a] = 0.062;
    for (int i = 1; i < 4; ++i) {
      if (i != a) want[i][i] = 0.070;
    }
    for (int i = 0; i < 4; ++i) {
      for (int j = 0; j < 4; ++j) {
        // To the printed precision: rounding to three decimals gives the printed value.
        EXPECT_NEAR(at(m[k], i, j), want[i][j], 0.0005)
            << "direction " << k << " (" << i << ", " << j << ")";
        if (want[i][j] == 0.0) {
          EXPECT_NEAR(at(m[k], i, j), 0.0, 1e-12);
        }
      }
    }
  }
  // The isotropic share in closed form: the five faces subtend the shared face's 2 pi / 3, and
  // 1/6 of an isotropic source's flux goes to each neighbour.
  EXPECT_NEAR(at(m[0], 0, 0), 1.0 / 6.0, 1e-12);
  std::printf(
      "+x: %.6f %.6f / %.6f %.6f / %.6f %.6f / %.6f %.6f (paper 0.167 0.240 / 0.070 / 0.070 / "
      "0.037 0.062)\n",
      at(m[0], 0, 0), at(m[0], 0, 3), at(m[0], 1, 1), at(m[0], 1, 2), at(m[0], 2, 2),
      at(m[0], 2, 1), at(m[0], 3, 0), at(m[0], 3, 3));
}

// The lobe and the radiance estimate against their integrals, by a Fibonacci sphere.
TEST(Lpv, CosineLobeAndAreaLightAreTheirIntegrals) {
  constexpr int kPoints = 200000;
  const glm::dvec3 n = glm::normalize(glm::dvec3(0.3, -0.5, 0.8));
  glm::dvec4 lobe(0.0);
  const glm::dvec4 c(0.7, 0.2, -0.1, 0.25);  // an intensity distribution
  double hemisphere_flux = 0.0;
  for (int i = 0; i < kPoints; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / kPoints;
    const double r = std::sqrt(1.0 - z * z), phi = i * std::numbers::pi * (3.0 - std::sqrt(5.0));
    const glm::dvec3 w(r * std::cos(phi), r * std::sin(phi), z);
    const double dw = 4.0 * std::numbers::pi / kPoints;
    lobe += lpvBasis(w) * std::max(0.0, glm::dot(n, w)) * dw;
    if (glm::dot(n, w) > 0.0) hemisphere_flux += glm::dot(c, lpvBasis(w)) * dw;
  }
  const glm::dvec4 want = lpvCosineLobe(n);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(lobe[i], want[i], 1e-4) << i;
  // Eq. 5: L A pi is the flux into the hemisphere about n.
  const double area = 0.01;
  EXPECT_NEAR(lpvAreaLightRadiance(c, n, area) * area * std::numbers::pi, hemisphere_flux, 1e-4);
}

// A 32^3 grid inside one medium (all but its outer layer), light injected at the centre: eight
// steps move it at most eight cells, so nothing leaves; with no absorption the flux is conserved
// step to step, with absorption sigma it falls by exp(-sigma dx) per step. Scattering does not
// change the flux.
TEST(Lpv, PropagationConservesFluxAndAbsorbsBeersLaw) {
  Bounds3 b;
  b.extend(glm::vec3(0.0f));
  b.extend(glm::vec3(0.03f));
  const LpvGrid grid = LpvGrid::around(b, 32);
  ASSERT_EQ(grid.size, glm::ivec3(32));
  // Every cell inside but the outer layer (which a voxelisation leaves outside).
  std::vector<LpvCell> cells(grid.cellCount(), LpvCell::kOutside);
  for (int z = 1; z < 31; ++z) {
    for (int y = 1; y < 31; ++y) {
      for (int x = 1; x < 31; ++x) cells[grid.index(glm::ivec3(x, y, z))] = LpvCell::kInside;
    }
  }
  for (const double sigma_a : {0.0, 50.0}) {
    for (const double s : {0.0, 0.6}) {
      LpvMedium medium;
      medium.extinction.assign(grid.cellCount(), glm::vec3(float(sigma_a)));
      medium.scattering.assign(grid.cellCount(), glm::vec3(float(s)));
      medium.g.assign(grid.cellCount(), 0.3f);
      LpvField a, b2, sent;
      a.resize(grid.cellCount());
      b2.resize(grid.cellCount());
      // A point light at the centre cell: an off-axis clamped-cosine lobe per channel.
      const size_t centre = grid.index(glm::ivec3(16));
      for (int ch = 0; ch < 3; ++ch) {
        a.c[size_t(ch)][centre] =
            glm::vec4(lpvCosineLobe(glm::normalize(glm::dvec3(1.0, 0.5 + ch, -0.3))) * 2.0);
      }
      const LpvTransfer transfer = lpvTransfer(grid, cells, medium);
      double worst = 0.0;
      const double per_step = std::exp(-sigma_a * grid.cell);
      for (int step = 0; step < 8; ++step) {
        const glm::dvec3 before = a.flux();
        lpvPropagate(grid, transfer, a, b2, sent);
        std::swap(a, b2);
        const glm::dvec3 after = a.flux();
        for (int ch = 0; ch < 3; ++ch) {
          worst = std::max(worst, std::abs(after[ch] / (before[ch] * per_step) - 1.0));
        }
      }
      std::printf("sigma_a %.0f /m, s %.1f: flux per step within %.2e of exp(-sigma dx) = %.6f\n",
                  sigma_a, s, worst, per_step);
      EXPECT_LT(worst, 1e-4);
    }
  }
}

// A UV sphere of radius r in a 32^3 grid: every cell whose centre is deeper than a cell's
// half-diagonal inside is an inside cell, every cell whose box the surface crosses is a boundary
// cell, everything farther out is outside; the inside and boundary cells hold the sphere's volume.
TEST(Lpv, VoxelisationFindsTheInsideAndTheBoundary) {
  const double radius = 0.05;
  std::vector<glm::vec3> positions;
  std::vector<glm::uvec3> triangles;
  const int rings = 48, segments = 96;
  for (int i = 0; i <= rings; ++i) {
    const double theta = std::numbers::pi * i / rings;
    for (int j = 0; j < segments; ++j) {
      const double phi = 2.0 * std::numbers::pi * j / segments;
      positions.emplace_back(float(radius * std::sin(theta) * std::cos(phi)),
                             float(radius * std::cos(theta)),
                             float(radius * std::sin(theta) * std::sin(phi)));
    }
  }
  for (int i = 0; i < rings; ++i) {
    for (int j = 0; j < segments; ++j) {
      const uint32_t a = uint32_t(i * segments + j),
                     b = uint32_t(i * segments + (j + 1) % segments);
      const uint32_t c = a + uint32_t(segments), d = b + uint32_t(segments);
      if (i > 0) triangles.emplace_back(a, b, c);
      if (i < rings - 1) triangles.emplace_back(b, d, c);
    }
  }
  Bounds3 bounds;
  for (const glm::vec3& p : positions) bounds.extend(p);
  const LpvGrid grid = LpvGrid::around(bounds, 32);
  const std::vector<LpvCell> cells = lpvVoxelise(grid, positions, triangles);
  const double half_diagonal = 0.5 * std::sqrt(3.0) * grid.cell;
  size_t wrong = 0, object = 0;
  for (int z = 0; z < grid.size.z; ++z) {
    for (int y = 0; y < grid.size.y; ++y) {
      for (int x = 0; x < grid.size.x; ++x) {
        const glm::ivec3 c(x, y, z);
        const double r = glm::length(grid.centre(c));
        const LpvCell kind = cells[grid.index(c)];
        if (kind != LpvCell::kOutside) ++object;
        // The faceted sphere lies within 0.1% of r of the true one here.
        if (r < radius * 0.999 - half_diagonal && kind != LpvCell::kInside) ++wrong;
        if (r > radius + half_diagonal && kind != LpvCell::kOutside) ++wrong;
        if (std::abs(r - radius) < 0.45 * grid.cell && kind != LpvCell::kBoundary) ++wrong;
      }
    }
  }
  const double volume = double(object) * std::pow(grid.cell, 3);
  const double sphere = 4.0 / 3.0 * std::numbers::pi * std::pow(radius, 3);
  std::printf("sphere in %dx%dx%d: %zu object cells, %.3f of the sphere's volume; %zu misplaced\n",
              grid.size.x, grid.size.y, grid.size.z, object, volume / sphere, wrong);
  EXPECT_EQ(wrong, 0u);
  // Boundary cells stick out by up to a cell: between the sphere and the sphere grown by one.
  EXPECT_GT(volume, sphere);
  EXPECT_LT(volume, 4.0 / 3.0 * std::numbers::pi * std::pow(radius + half_diagonal, 3));
}

}  // namespace
}  // namespace penumbra
