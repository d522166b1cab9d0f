// What `render --method matrix` and `bake --method matrix` share: building the system with the
// form factors' progress on the terminal (rank 0's), over the current communicator's ranks.
#pragma once

#include "penumbra/methods/render.h"
#include "penumbra/radiosity/matrix_radiosity.h"

namespace penumbra {

Expected<MatrixRadiosity> buildMatrixWithProgress(const Scene& scene,
                                                  const MatrixRadiosityOptions& options,
                                                  const CommonOptions& common);

}  // namespace penumbra
