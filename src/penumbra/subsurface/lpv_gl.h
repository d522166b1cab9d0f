// The propagation of subsurface light propagation volumes (Børlum et al. 2011, sec. 3.2 and 4)
// on the GPU (OpenGL 4.5 compute on 3D textures), the twin of LpvSolver's CPU steps: per object
// its cells' kinds and transfer factors go up when the geometry changes, the injected field
// every frame (48 bytes per cell); `steps` dispatches of shaders/subsurface/lpv_propagate.comp
// ping-pong between two propagation fields and add into the accumulation field after the first
// `skip_steps`, which comes back (48 bytes per cell) for the view. Both devices compute the
// same float operations in the same order (tests/subsurface/lpv_gl_test.cpp states the
// agreement).
//
// Needs a current OpenGL context (gpu/context.h) on the calling thread.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/gpu/objects.h"
#include "penumbra/subsurface/lpv_volume.h"

#include <array>
#include <cstddef>
#include <span>
#include <vector>

namespace penumbra {

class GlLpv {
 public:
  // Compiles the shader. Fails (as a value) when it does not compile.
  static Expected<GlLpv> create();

  // The volume of object k after its geometry changed: its cells and transfer factors
  // (textures are made anew when the grid's size changed).
  Status setVolume(size_t k, const LpvGrid& grid, std::span<const LpvCell> cells,
                   const LpvTransfer& transfer);
  // Sec. 3.2 for object k: from the injected field, `steps` steps, the accumulation of all but
  // the first `skip_steps`, downloaded into `accumulated` (resized to the grid's cells).
  Status propagate(size_t k, const LpvField& injected, int steps, int skip_steps,
                   LpvField& accumulated);

 private:
  struct Volume {
    glm::ivec3 size{0};
    gl::Texture cells;
    std::array<gl::Texture, 3> scale, accumulated;
    std::array<std::array<gl::Texture, 3>, 2> field;
  };
  gl::Program propagate_;
  std::vector<Volume> volumes_;
};

}  // namespace penumbra
