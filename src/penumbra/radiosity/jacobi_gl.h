// Matrix radiosity's Jacobi iteration on the GPU (OpenGL 4.5 compute), as Carr, Hall and Hart
// (2003, sec. 3) run it: the full matrix-vector form of eq. 4,
//   B' = B + diag(M)^-1 (E - M B),  M = I - diag(rho) F  (eq. 2),
// with no j != i branch (eq. 3), the form factors resident on the GPU and every product done in
// passes over blocks of columns. The CPU twin is jacobiStep (matrix_solver.h); the two agree
// within 1e-5 relative after every iteration (tests/radiosity/jacobi_gl_test.cpp).
//
// One iteration is three dispatches (shaders/radiosity/jacobi.comp):
//  1. product: a 2-D grid of (column block) x (row tile) work groups. A group loads the block's
//     segment of B into shared memory and writes one partial sum (F B)_i over the block for
//     each row i of its tile: partials[block][i]. F is read once for the three channels.
//  2. update: per row, the partials summed in block order, then eq. 4 and the row's squared
//     residual |(M B - E)_i|^2.
//  3. reduce: one group sums the per-row squared residuals in a fixed tree.
// Every sum has a fixed order (no atomics), so results do not depend on scheduling. Only the
// residual (8 bytes) comes back per iteration; B crosses the bus in upload() and download().
//
// Needs a current OpenGL context (gpu/context.h) on the calling thread.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/gpu/objects.h"
#include "penumbra/radiosity/matrix_solver.h"

#include <glm/vec3.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

namespace penumbra {

// ---- GPU layouts (std430), mirrored in shaders/radiosity/jacobi_layout.glsl ----

// Work decomposition of the product pass, handed to the shader as #defines.
// Carr et al. (sec. 3) pick their block of 254 columns from the GeForce FX's 1024 fragment
// instructions per pass. A compute shader has no such limit; what bounds the block here is the
// shared memory holding its B segment and the number of groups in flight. 256 columns keep the
// segment at 3 KiB (with the 12 KiB row-reduction scratch, well under the 32 KiB every GL 4.5
// device offers), make each lane's share of a row a whole number of coalesced 128-byte reads
// (8 fp32 or 4 packed-fp16 words per lane), and still give ceil(N / 256) x ceil(N / 32)
// groups: 2 x 16 for N = 500, 32 x 125 for N = 4000.
inline constexpr uint32_t kJacobiBlockColumns = 256;
// A row is read by 32 adjacent lanes (a warp on NVIDIA, half a wave on AMD): consecutive
// lanes read consecutive words of F, so every read is coalesced.
inline constexpr uint32_t kJacobiLanes = 32;
// 8 rows of lanes per group (256 invocations), each doing 4 rows: a group covers 32 rows, so
// the shared B segment serves 32 x 256 form factors.
inline constexpr uint32_t kJacobiWarps = 8;
inline constexpr uint32_t kJacobiRowsPerWarp = 4;
inline constexpr uint32_t kJacobiRowsPerGroup = kJacobiWarps * kJacobiRowsPerWarp;
// Invocations per group of the update pass (one per row) and of the final reduction.
inline constexpr uint32_t kJacobiUpdateGroup = 64;
inline constexpr uint32_t kJacobiReduceGroup = 256;

// An RGB value per element (B, and the product's partial sums): 16 bytes.
struct GpuRgb {
  float rgb[3];
  float pad;
};
static_assert(sizeof(GpuRgb) == 16 && offsetof(GpuRgb, pad) == 12);

// What eq. 4 needs per element besides F and B: 32 bytes.
struct GpuJacobiElement {
  float reflectance[3];    // rho_i per channel
  float self_form_factor;  // F_ii as stored (diag(M)_ii = 1 - rho_i F_ii)
  float emission[3];       // E_i (W m^-2)
  float pad;
};
static_assert(sizeof(GpuJacobiElement) == 32 &&
              offsetof(GpuJacobiElement, self_form_factor) == 12 &&
              offsetof(GpuJacobiElement, emission) == 16);

// The matrix buffer: fp32 as float[N * N] row-major; fp16 as the CPU's binary16 bits packed two
// per uint (column 2k in the low half, unpackHalf2x16), rows padded to an even length with 0.
// The per-row squared residuals are double[N]; the reduction writes double[2] (two slots, so
// the residual of one iteration can be read while the next runs).

// ---- The solver ----

class GlJacobi {
 public:
  // Uploads F (as stored: fp32 or fp16 bits), the materials and B = 0. Fails, as a value, when
  // the shaders do not compile, a buffer exceeds the device's GL_MAX_SHADER_STORAGE_BLOCK_SIZE
  // (or `max_buffer_bytes` when that is smaller and non-zero: a smaller device, for tests) or
  // the dispatch limits, or the device is out of memory.
  static Expected<GlJacobi> create(const RadiositySystem& system, int64_t max_buffer_bytes = 0);

  GlJacobi(GlJacobi&&) noexcept = default;
  GlJacobi& operator=(GlJacobi&&) noexcept = default;
  GlJacobi(const GlJacobi&) = delete;
  GlJacobi& operator=(const GlJacobi&) = delete;
  ~GlJacobi() = default;

  uint32_t size() const { return n_; }
  MatrixPrecision precision() const { return precision_; }
  // Column blocks of the product: ceil(N / kJacobiBlockColumns), passes per iteration in the
  // paper's terms (sec. 3: ceil(N / 254)).
  uint32_t blocks() const { return blocks_; }

  // Dynamic relighting (sec. 1, 3): new reflectances and emissions, F stays on the GPU. The
  // current B is kept (a warm start). Sizes must be N.
  Status setMaterials(std::span<const glm::vec3> reflectance, std::span<const glm::vec3> emission);

  // Sets / reads the current iterate B (size N).
  Status upload(std::span<const glm::vec3> b);
  Status download(std::vector<glm::vec3>& b) const;

  // One Jacobi iteration (eq. 4) on the GPU: the current B becomes B'. Returns the mean squared
  // residual of M B - E ((W m^-2)^2) of the B it started from, as jacobiStep does.
  Expected<double> step();
  // The mean squared residual of the current B (meanSquaredResidual), B unchanged.
  Expected<double> residual();

  // solveRadiosity on the GPU, Jacobi only (options.solver must be kJacobi): iterates from `b`
  // until the residual is at most the tolerance or the iteration cap; `b` holds the result.
  // history[k] is the residual of iterate k, then the residual of the returned B is appended;
  // `after_iteration(k, history[k])` is called after each iteration.
  Expected<SolveStats> solve(std::vector<glm::vec3>& b, const SolveOptions& options,
                             const std::function<void(int, double)>& after_iteration = {});

 private:
  GlJacobi() = default;
  // Queues one iteration reading B[current_], writing B[1 - current_] and the residual to
  // `slot`; `advance` makes the output current.
  void dispatch(int slot, bool advance);
  // Waits for the sum of squared residuals in `slot`; returns their mean (meanSquaredResidual).
  double readResidual(int slot);
  Status glStatus(const char* what) const;

  uint32_t n_ = 0, blocks_ = 0, row_words_ = 0;
  MatrixPrecision precision_ = MatrixPrecision::kFp32;
  std::vector<float> self_form_factor_;  // F_ii, for setMaterials
  gl::Program product_, update_, reduce_;
  gl::Buffer matrix_, elements_, partials_, row_residual_, result_;
  std::array<gl::Buffer, 2> b_;
  int current_ = 0;
  const double* result_map_ = nullptr;  // persistently mapped result_: double[2]
  std::array<gl::Fence, 2> result_fence_;
};

}  // namespace penumbra
