// Luminaires from photometric files: a manufacturer's EULUMDAT or IES file (io/photometry.h)
// made into the light distribution texture the lights read (scene/luminaire.h, Wallner sec. 3.2).
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/io/photometry.h"
#include "penumbra/scene/luminaire.h"

#include <memory>
#include <string>

namespace penumbra {

// The LDT of `photometry`: resampled on a regular type C grid as fine as the file's own (its
// smallest gamma and C spacings, at least 0.25 and 0.5 degrees: at most 721 x 720 values), types
// A and B on a 1-degree grid. Intensities in cd, TILT applied at `tilt_degrees` (0 = as
// measured).
Expected<std::shared_ptr<const LuminaireDistribution>> luminaireDistribution(
    const Photometry& photometry, double tilt_degrees = 0.0);

// Reads the file and makes its LDT.
Expected<std::shared_ptr<const LuminaireDistribution>> loadLuminaireDistribution(
    const std::string& path, double tilt_degrees = 0.0);

}  // namespace penumbra
