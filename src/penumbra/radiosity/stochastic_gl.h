// Stochastic radiosity on the GPU (Barsi and Jakab), the first part: shooter selection (sec. 3.1)
// built and descended on the device. The paper read the radiosity back to pick a texel and found
// that readback ten times dearer than everything else; here the mipmap of lum(B) A (over the
// chart atlas's hierarchy, the CPU solver's StochasticRadiosity::select) is summed level by level
// in compute passes and descended by one invocation, and only the choice (32 bytes) comes back.
// The same u picks the same texel as the CPU: the same hierarchy, sums in double in the same
// order, the same descent (shaders/radiosity/stochastic.comp).
//
// Not yet on the GPU: the shooting (the depth-map update pass) and the average; `render --method
// stochastic --device gpu` is refused.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/gpu/objects.h"
#include "penumbra/radiosity/stochastic.h"

#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace penumbra {

struct GpuStochasticSelection {  // 32 bytes, std430
  uint32_t element;
  uint32_t found;  // 0: nothing has weight
  double probability;
  double power;
  double pad;
};
static_assert(sizeof(GpuStochasticSelection) == 32);

class GlStochasticSelection {
 public:
  // The hierarchy of `cpu`'s lightmap and its elements' areas, on the device; needs a current
  // OpenGL 4.5 context with double precision in shaders.
  static Expected<GlStochasticSelection> create(const StochasticRadiosity& cpu);

  // The radiosity per element (W m^-2) the selection draws from (the GPU solver will keep it on
  // the device; the CPU's iterate for now).
  Status upload(std::span<const glm::dvec3> radiosity);
  // Builds the sums and descends them for u in [0, 1): the texel and its probability.
  Expected<GpuStochasticSelection> select(double u);

 private:
  GlStochasticSelection() = default;
  size_t elements_ = 0;
  uint32_t charts_ = 0;
  std::vector<uint32_t> level_size_, level_offset_, first_offset_;
  gl::Program texels_, level_, descent_;
  gl::Buffer iterate_, area_, sums_, child_first_, roots_, selection_;
};

}  // namespace penumbra
