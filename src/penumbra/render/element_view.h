// A camera's view of a solution stored per element (radiosity methods): primary rays against the
// element mesh, each hit shaded with the radiance interpolated from the element's corners (the
// smooth display of Carr, Hall, Hart 2003, sec. 3.1) or, flat, the element's own value.
#pragma once

#include "penumbra/core/image.h"
#include "penumbra/radiosity/elements.h"
#include "penumbra/scene/camera.h"

#include <glm/vec3.hpp>

#include <cstdint>
#include <span>

namespace penumbra {

struct ElementViewSettings {
  int width = 512;
  int height = 512;
  int spp = 4;  // jittered primary rays per pixel (antialiasing)
  uint64_t seed = 0;
};

// `corner_radiance` has 3 entries per element (corner k of element e at 3 e + k, as
// Elements::cornerAverage gives them); for a flat view pass each element's value three times.
// Back faces (elements are one-sided) and misses are black. Pixels are independent of the
// thread count.
Image renderElementView(const Elements& elements, std::span<const glm::vec3> corner_radiance,
                        const Camera& camera, const ElementViewSettings& settings);

}  // namespace penumbra
