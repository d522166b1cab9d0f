#include "penumbra/render/sss_frames.h"

#include "penumbra/core/timer.h"

namespace penumbra {

Expected<SssFrames> SssFrames::create(const SssSolver& solver, const Camera& camera,
                                      const SssViewSettings& view, bool gpu) {
  SssFrames f;
  f.solver_ = &solver;
  if (gpu) {
    Expected<GlSss> g = GlSss::create(solver);
    if (!g) return g.error();
    f.gpu_ = std::make_unique<GlSss>(std::move(*g));
  }
  const Timer timer;
  f.view_ = SssView::trace(solver, camera, view);
  f.view_seconds_ = timer.seconds();
  return f;
}

Expected<SssFrame> SssFrames::render(std::span<const Light> lights, uint64_t* rays) {
  SssFrame frame;
  std::vector<glm::vec3> b;
  if (gpu_) {
    PENUMBRA_TRY(gpu_->frame(lights, b, &frame.times));
  } else {
    const Timer t1;
    const std::vector<glm::vec3> e = solver_->transmittedIrradiance(lights, rays);
    frame.times.irradiance = t1.seconds();
    const Timer t2;
    b = solver_->scatter(e);
    frame.times.gather = t2.seconds();
  }
  const Timer t3;
  const Image atlas = solver_->scatteredRadianceAtlas(b);
  frame.image = view_->render(*solver_, atlas, lights, rays);
  frame.times.image = t3.seconds();
  return frame;
}

}  // namespace penumbra
