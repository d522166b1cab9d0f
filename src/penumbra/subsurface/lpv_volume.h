// The light propagation volume of SSLPV (Børlum et al. 2011, sec. 3.2 and 4): a regular grid of
// cubic cells around a translucent object, its cells sorted each frame by a voxelisation of the
// current mesh (no precomputation: the mesh may deform and change topology), the medium per cell,
// and the propagation step that moves light between axial neighbours with the matrices of
// subsurface/lpv_sh.h, absorbing (sec. 3.2.1) and scattering (eq. 3) on the way.
//
// A cell holds, per colour channel, the two-band coefficients (c00, c1-1, c10, c11) of the
// intensity (W sr^-1) of the point light at its centre. Light propagates only through the
// object's cells (inside and boundary): light reaching a cell outside has left the object and
// is dropped. (The paper propagates through the whole grid and notes, Fig. 8, that light which
// has left keeps dissipating back in; dropping it is what it names as future work.)
#pragma once

#include "penumbra/accel/bounds.h"
#include "penumbra/core/expected.h"
#include "penumbra/scene/material.h"

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace penumbra {

// Grid resolutions the command line takes: 32 by default, up to 128 (sec. 4, Table 1).
inline constexpr int kLpvDefaultGrid = 32;
inline constexpr int kLpvMaxGrid = 128;

struct LpvGrid {
  glm::ivec3 size{0};
  glm::dvec3 origin{0.0};  // the corner of cell (0, 0, 0)
  double cell = 1.0;       // edge length (m)

  // Cubic cells, `resolution` of them along the bounds' longest side plus a margin of one cell
  // on every side (so that every surface point has a cell and every boundary cell neighbours
  // outside cells), the others as many as the bounds need.
  static LpvGrid around(const Bounds3& bounds, int resolution);

  size_t cellCount() const { return size_t(size.x) * size_t(size.y) * size_t(size.z); }
  size_t index(const glm::ivec3& c) const {
    return (size_t(c.z) * size_t(size.y) + size_t(c.y)) * size_t(size.x) + size_t(c.x);
  }
  bool contains(const glm::ivec3& c) const {
    return c.x >= 0 && c.y >= 0 && c.z >= 0 && c.x < size.x && c.y < size.y && c.z < size.z;
  }
  glm::dvec3 centre(const glm::ivec3& c) const { return origin + (glm::dvec3(c) + 0.5) * cell; }
  // The cell a point lies in (clamped to the grid).
  glm::ivec3 cellOf(const glm::dvec3& p) const;
};

enum class LpvCell : uint8_t { kOutside = 0, kInside = 1, kBoundary = 2 };

// Sec. 3 / Fig. 2, every frame: boundary cells overlap a triangle of the mesh (the separating
// axis test of a triangle against the cell's box), inside cells are the others whose centre lies
// inside the mesh (an odd number of crossings along +x from the centre, row by row). The grid's
// outer layer stays outside (LpvGrid::around keeps the mesh a cell away from it). The mesh
// should be closed; open meshes give boundary cells along the surface and whatever inside the
// parity finds.
std::vector<LpvCell> lpvVoxelise(const LpvGrid& grid, std::span<const glm::vec3> positions,
                                 std::span<const glm::uvec3> triangles);

// The medium per cell, the paper's three grids (sec. 3.2, 4): the extinction that attenuates a
// transfer between cells by exp(-sigma dx) per channel (m^-1), the dimensionless amount of
// scattering s in [0, 1] of eq. 2 and the Henyey-Greenstein mean cosine g.
struct LpvMedium {
  std::vector<glm::vec3> extinction;
  std::vector<glm::vec3> scattering;  // per channel
  std::vector<float> g;
};

// A homogeneous medium from the subsurface block the dipole method takes (scene/material.h),
// over every cell of the grid. The paper's extinction attenuates light that its scattering then
// redistributes; from a physical medium it is the absorption sigma_a (the scattered part is not
// lost, so counting it as extinction too would remove it twice), and s = 1 - exp(-sigma_s dx)
// is the share of light a cell's width scatters, sigma_s = sigma_s' / (1 - g).
LpvMedium lpvHomogeneousMedium(const LpvGrid& grid, const Subsurface& medium);
// The same per cell from a heterogeneous medium (scene/heterogeneous_media.h) over the mesh's
// bounding box `box` (cells outside it take its nearest face's values).
LpvMedium lpvMedium(const LpvGrid& grid, const Subsurface& medium, const Bounds3& box);

// Intensity coefficients per channel per cell.
struct LpvField {
  std::array<std::vector<glm::vec4>, 3> c;
  void resize(size_t cells);
  void clear();
  // The total flux per channel, sum over cells of sqrt(4 pi) c00 (W).
  glm::dvec3 flux() const;
};

// What a frame's propagation needs of the medium, computed once per frame: the object's cells
// (the indices of the inside and boundary cells, in order, less any on the grid's outer layer) and,
// per channel and cell, the factors a cell's coefficients are sent with: exp(-sigma dx) for band 0
// and exp(-sigma dx) ((1 - s) + s g) for band 1 (sec. 3.2.1 and eq. 3).
struct LpvTransfer {
  std::vector<uint32_t> cells;
  std::array<std::vector<glm::vec4>, 3> scale;
};
LpvTransfer lpvTransfer(const LpvGrid& grid, std::span<const LpvCell> cells,
                        const LpvMedium& medium);

// One propagation step (sec. 3.2): every cell of the object gathers from its six axial
// neighbours of the object their coefficients times the transfer's factors, through the
// propagation matrices (whose structure, six non-zero entries each, it uses); the other cells of
// `to` are left as they are (zero when `to` started zero). `sent` is scratch space (the factors
// applied), zero outside the object. Runs on all threads (oneTBB), the same result for any
// thread count.
void lpvPropagate(const LpvGrid& grid, const LpvTransfer& transfer, const LpvField& from,
                  LpvField& to, LpvField& sent);

}  // namespace penumbra
