// Emitters modelled flat on another surface: "a panel in the ceiling" drawn as a quad lying on an
// unbroken ceiling. The two surfaces then coincide, every ray that reaches them hits whichever
// the hierarchy happens to test first, and the ceiling hides much of the panel (a CIE 171 case
// 5.3 room modelled this way came out 68-77% too dark).
//
// What the user means is the panel: its triangles are lifted off the surface they lie on, along
// their front normal, by
//   delta = max(1e-4 x the triangle's longest edge, 1e-6 x its distance from the origin),
// far below any modelling tolerance and far above single precision's rounding of hit distances,
// so that rays from the front meet the emitter first. The covered part of the surface stays,
// hidden behind the panel's back. Lifted corners get vertices of their own (the surface keeps
// its), so triangle numbering and every other triangle are unchanged.
//
// Coincidence: the emitter triangle's plane is parallel to the surface triangle's
// (|n_e . n_s| > 1 - 1e-6), its corners lie within 1e-5 x its longest edge of the surface's
// plane, and the two overlap with area in the plane (the separating-axis test with a margin, so
// that an emitter filling a hole, which only shares edges with the surface around it, does not
// count).
#pragma once

#include "penumbra/scene/scene.h"

#include <cstddef>

namespace penumbra {

// Lifts every emitter triangle that lies on a non-emitting surface as above and adds one warning
// per (emitter material, surface mesh) pair to scene.warnings, which `info` lists. Returns the
// number of triangles lifted. Idempotent: a lifted emitter no longer coincides.
size_t liftCoplanarEmitters(Scene& scene);

}  // namespace penumbra
