// The scene format's daylight (docs/scene-format.md, "Daylight"): "sky" (a CIE standard general
// sky, the sun's position from elevation and azimuth or from date, time and place, its beam,
// the ground) and "openings" (windows and roof lights, glazed or not).
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/scene/light.h"
#include "penumbra/scene/sky.h"

#include <nlohmann/json_fwd.hpp>

#include <optional>
#include <string>
#include <vector>

namespace penumbra {

struct DaylightSky {
  Sky sky;                              // prepared
  std::optional<DirectionalLight> sun;  // the beam, when "sun_illuminance" > 0
};

// `j` at `place` of `file`; every value checked (type 1-16, luminances finite and at most 1e9,
// the sun above the horizon, reflectance in [0, 1], a real date and time).
Expected<DaylightSky> readSky(const nlohmann::json& j, const std::string& file,
                              const std::string& place);

// A list of openings: {"name", "corners": [[x, y, z], ...] (a convex polygon of 3 to 16
// corners), "glazing": {"transmittance": tau_n, "ior": n}}.
Expected<std::vector<Opening>> readOpenings(const nlohmann::json& j, const std::string& file,
                                            const std::string& place);

}  // namespace penumbra
