// Pass 3 of the subsurface method (Carr, Hall, Hart 2003, sec. 4.2.4) on the CPU: a camera's
// view of the scattered irradiance map. The camera's rays are traced once (`SssView::trace`,
// jittered samples per pixel); each frame then costs only lookups, so a moving light costs the
// three passes and not the view's geometry:
//
//  - a translucent surface point: L = F_t(eta, cos theta_o) B / pi (eq. 6), B looked up
//    bilinearly in the atlas (which never mixes charts), theta_o from the shading normal;
//  - an opaque one: its direct light, rho / pi sum_lights E V (one shadow ray per light), plus
//    its emission;
//  - the back of a one-sided surface: black; misses: the scene's environment.
#pragma once

#include "penumbra/core/image.h"
#include "penumbra/scene/camera.h"
#include "penumbra/subsurface/sss.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstdint>
#include <span>
#include <vector>

namespace penumbra {

struct SssViewSettings {
  int width = 512;
  int height = 512;
  int spp = 4;  // jittered primary rays per pixel
  uint64_t seed = 0;
};

class SssView {
 public:
  static SssView trace(const SssSolver& solver, const Camera& camera,
                       const SssViewSettings& settings);

  // The image from a scattered radiance atlas (SssSolver::scatteredRadianceAtlas) and the
  // lights of this frame. Adds the shadow rays to *rays.
  Image render(const SssSolver& solver, const Image& scattered_atlas, std::span<const Light> lights,
               uint64_t* rays = nullptr) const;

  size_t translucentSamples() const { return translucent_.size(); }

 private:
  struct Translucent {
    uint32_t pixel;
    glm::vec2 uv;
    float weight;  // F_t(eta, cos theta_o) / spp
  };
  struct Opaque {
    uint32_t pixel;
    glm::vec3 point, normal;  // normal: the side the camera sees
    glm::vec3 reflectance;    // rho / spp
  };
  int width_ = 0, height_ = 0;
  float lift_ = 0.0f;
  std::vector<Translucent> translucent_;
  std::vector<Opaque> opaque_;
  std::vector<glm::vec3> emitted_;  // per pixel, constant
};

}  // namespace penumbra
