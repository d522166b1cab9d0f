// The `subsurface` block of a material, as the JSON scene format and Penumbra's glTF extension
// (PENUMBRA_materials_subsurface) write it (docs/scene-format.md):
//
//   "subsurface": "marble"                                   a measured material (Jensen 2001)
//   "subsurface": {"preset": "skin1", "eta": 1.4, "scale": 2}
//   "subsurface": {"sigma_s_prime": [2.19, 2.62, 3.0], "sigma_a": [0.0021, 0.0041, 0.0071],
//   "eta": 1.3} "subsurface": {"albedo": [0.8, 0.6, 0.5], "distance_mm": [4, 2, 1]}
//
// sigma_s_prime (the reduced scattering coefficient sigma_s') and sigma_a are per millimetre;
// albedo is the diffuse reflectance the medium shows and distance_mm how far light diffuses in it
// (1 / sigma_tr). "scale" multiplies the coefficients (2: twice as dense, light travels half as
// far). "g" is the Henyey-Greenstein mean cosine of the phase function (default 0; the dipole works
// with the reduced coefficients and does not use it). A colour may be a single number for grey.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/scene/material.h"

#include <nlohmann/json.hpp>

#include <string>

namespace penumbra {

// Errors name `file` and the key path below `place` ("materials.stone.subsurface.eta").
Expected<Subsurface> parseSubsurface(const nlohmann::json& block, const std::string& file,
                                     const std::string& place);

}  // namespace penumbra
