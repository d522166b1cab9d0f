// Stochastic radiosity on the GPU (Barsi and Jakab), the twin of StochasticRadiosity
// (stochastic.h) on the same chart atlas, elements, E', random numbers and burn-in.
//
//  - Shooter selection (sec. 3.1), GlStochasticSelection: the mipmap of lum(B) A (over the chart
//    atlas's hierarchy, the CPU's StochasticRadiosity::select) summed level by level in compute
//    passes and descended by one invocation; only the choice (64 bytes: the texel, its
//    probability, Phi and its radiosity) comes back. The paper read the radiosity back to pick
//    a texel and found that readback ten times dearer than everything else. The same u picks
//    the same texel as the CPU from the same iterate: the same hierarchy, sums in double in the
//    same order, the same descent (shaders/radiosity/stochastic.comp).
//  - The random operator (eq. 3), GlStochastic: the chosen texel j sends B_j w / P_j (w = 1 /
//    shooters) through the hemispherical gather that progressive radiosity uses
//    (hemisphere_gl.h): its depth map (Algorithm 1) from j's point around j's normal, then
//    every element back-projected into it (Fig. 3's test with its depth tolerance: the update
//    pass of sec. 3.2) gathers eq. 2's disc form factor times what j sends, or Lambert's exact
//    form factor to j's pieces within kStochasticNear of j's size, as the CPU does; pairs within
//    kStochasticLocal are left to the local operator, whose pairs and factors (with the CPU's
//    shadow rays, computed once) are uploaded and applied to the whole iterate each iteration
//    (a compute pass). The update pass forms B_m = E' + rho (E_local + E_in) per element in
//    double, and adds it to the running sums by parity (eq. 2) after the burn-in: the iterate
//    and the average stay on the device. The first shots are the CPU solver's (stochastic.h).
//  - The error estimate (the CPU's: half the difference of the odd and even means against the
//    mean, relative RMS over the elements, area-weighted luminance) is reduced on the device
//    per work group; download() brings the state back for checkpoints and the lightmap.
//
// The two devices draw the same random numbers and agree in distribution, not per iteration:
// depth maps and rays part at grazing angles and contact shadows, and an iterate that differs
// in the last bits can pick another texel for the same u (tests/radiosity/stochastic_gl_test.cpp
// measures the agreement). Needs a current OpenGL 4.5 context with double precision in shaders.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/gpu/objects.h"
#include "penumbra/radiosity/hemisphere_gl.h"
#include "penumbra/radiosity/stochastic.h"

#include <glm/vec3.hpp>

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

namespace penumbra {

struct GpuStochasticSelection {  // 64 bytes, std430
  uint32_t element;
  uint32_t found;  // 0: nothing has weight
  double probability;
  double power;
  double pad;
  double value[4];  // the texel's radiosity B_j (W m^-2)
};
static_assert(sizeof(GpuStochasticSelection) == 64 &&
              offsetof(GpuStochasticSelection, value) == 32);

class GlStochasticSelection {
 public:
  // The hierarchy of `cpu`'s lightmap and its elements' areas, on the device; needs a current
  // OpenGL 4.5 context with double precision in shaders.
  static Expected<GlStochasticSelection> create(const StochasticRadiosity& cpu);

  GlStochasticSelection() = default;  // empty: create() makes a usable one

  // The radiosity per element (W m^-2) the selection draws from: the iterate buffer's contents.
  Status upload(std::span<const glm::dvec3> radiosity);
  // Sums the mipmap of the iterate buffer's current contents (passes 0 and 1).
  void build();
  // Descends the sums for u in [0, 1): the texel, its probability and radiosity.
  Expected<GpuStochasticSelection> descend(double u);
  // build() then descend(u).
  Expected<GpuStochasticSelection> select(double u);
  // The iterate (dvec4 per element) and the elements' areas (double), for the solver's passes.
  const gl::Buffer& iterate() const { return iterate_; }
  const gl::Buffer& area() const { return area_; }
  // Bytes of buffers a selection over `cpu` holds on the device.
  static uint64_t deviceBytes(const StochasticRadiosity& cpu);

 private:
  size_t elements_ = 0;
  uint32_t charts_ = 0;
  std::vector<uint32_t> level_size_, level_offset_, first_offset_;
  gl::Program texels_, level_, descent_;
  gl::Buffer iterate_, area_, sums_, child_first_, roots_, selection_;
};

class GlStochastic {
 public:
  // Uploads the atlas, the elements, E' and `cpu`'s state (iterate, sums, iterations), and takes
  // its options (iterations, time limit, shooters, seed, burn-in, visibility). Keeps a reference
  // to `cpu` (its surface and first shots): `cpu` must outlive it, unmoved. Fails
  // as an input error naming the bytes before allocating when the device cannot hold the work
  // (texture and storage-block sizes, memory); as a run-time error when a shader does not
  // compile.
  static Expected<GlStochastic> create(const StochasticRadiosity& cpu,
                                       const GlProgressiveOptions& gl_options = {});

  GlStochastic(GlStochastic&&) noexcept = default;
  GlStochastic& operator=(GlStochastic&&) noexcept = default;
  GlStochastic(const GlStochastic&) = delete;
  GlStochastic& operator=(const GlStochastic&) = delete;
  ~GlStochastic() = default;

  // One iteration (options.shooters random operators), from the same random numbers as the
  // CPU's iteration of the same number.
  Expected<StochasticIteration> step();
  // Iterates until the iteration cap or the time limit (StochasticRadiosity::solve).
  Expected<StochasticStats> solve(const std::function<void(const StochasticIteration&)>& after = {},
                                  const std::function<bool()>& stop = {});

  int iterations() const { return iterations_; }
  int burnIn() const { return burn_in_; }
  int averaged() const { return std::max(iterations_ - burn_in_, 0); }
  size_t elementCount() const { return elements_; }
  uint64_t deviceBytes() const { return gather_.deviceBytes(); }
  // The running error estimate (StochasticRadiosity::errorEstimate), reduced on the device.
  Expected<double> errorEstimate();
  // The state in the CPU solver's element order, and restoring one (checked as the CPU does).
  Expected<StochasticState> download();
  Status upload(const StochasticState& state);
  // The running average B~ per element (the iterate during the burn-in).
  Expected<std::vector<glm::dvec3>> radiosity();
  // Outgoing radiance B~ / pi per atlas texel, gaps filled (RadiositySurface::radianceImage).
  Expected<Image> radianceImage();

 private:
  GlStochastic() = default;
  // Adds T*_j B_{m-1} (weight / p) into the incident atlas (as irradiance; the update pass
  // multiplies by rho).
  void shoot(const GpuStochasticSelection& sel, double weight);
  Status glStatus(const char* what) const;

  StochasticOptions options_;
  const StochasticRadiosity* cpu_ = nullptr;
  size_t elements_ = 0;
  int iterations_ = 0;
  int burn_in_ = 0;
  std::vector<glm::uvec2> chart_elements_;
  GlHemisphereGather gather_;
  GlStochasticSelection selection_;
  gl::Program update_, error_, local_;
  gl::Buffer source_, sums_, partial_;
  gl::Buffer local_first_, local_pairs_, local_in_;  // the local operator, and its irradiance
  gl::Texture sent_;  // the chosen texel's B_j w / P_j, for the near pass
};

}  // namespace penumbra
