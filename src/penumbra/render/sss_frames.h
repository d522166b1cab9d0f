// Frames of the subsurface method with a moving light: the three passes (Carr, Hall, Hart 2003,
// sec. 4.2) on the device asked for, for the CLI, the viewer and the bindings alike. The camera's
// view is traced once; each frame runs pass 1 and 2 on the CPU (SssSolver) or the GPU (GlSss,
// needing a current OpenGL context) and pass 3 (SssView) on the CPU, and times each pass.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/render/sss_view.h"
#include "penumbra/subsurface/sss.h"
#include "penumbra/subsurface/sss_gl.h"

#include <memory>
#include <optional>
#include <span>

namespace penumbra {

struct SssFrame {
  Image image;
  SssPassTimes times;
};

class SssFrames {
 public:
  // `solver` must outlive the frames. With `gpu`, uploads the links and the tree (a current
  // OpenGL 4.5 context is needed).
  static Expected<SssFrames> create(const SssSolver& solver, const Camera& camera,
                                    const SssViewSettings& view, bool gpu);

  // One frame for these lights. Adds the rays traced on the CPU to *rays.
  Expected<SssFrame> render(std::span<const Light> lights, uint64_t* rays = nullptr);

  double viewSeconds() const { return view_seconds_; }

 private:
  const SssSolver* solver_ = nullptr;
  std::optional<SssView> view_;
  std::unique_ptr<GlSss> gpu_;
  double view_seconds_ = 0.0;
};

}  // namespace penumbra
