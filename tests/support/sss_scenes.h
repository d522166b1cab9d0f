// Scenes the subsurface methods are checked on against the path tracer's random walk, which
// cannot see point lights through a smooth boundary: emitters it can find instead.
#pragma once

#include "penumbra/scene/scene.h"

namespace penumbra::test {

// The built-in sss scene (the bunny in marble) with its point lights replaced by a 0.3 m square
// emitter of radiance 4 behind and to the side of the bunny, facing it, and a sky of radiance
// 0.02.
Scene areaLitBunny();

// A 20 x 20 mm slab of marble, `thickness_mm` thick (x and z in [0, 20] mm, top at y =
// thickness), under a 60 mm square emitter of radiance `radiance` facing down 30 mm above its
// top, seen straight down from 20 mm above through a narrow camera on the middle 2 mm of its
// top. No environment.
Scene areaLitMarbleSlab(double thickness_mm, float radiance);

// A square emitter of side `size` centred at `at`, its emitting side facing along unit `n`.
Mesh squareEmitter(const glm::vec3& at, const glm::vec3& n, float size, uint32_t material);

}  // namespace penumbra::test
