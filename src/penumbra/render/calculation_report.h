// Reports of calculation objects, as lighting designers hand them to clients: per object a CSV
// of its points, a JSON of its figures (E_avg, E_min, E_max, U0 = E_min / E_avg,
// U1 = E_min / E_max, direct and total) with every point, and for a plane grid a plan-view
// false-colour picture with the lux printed in each cell and a legend.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/render/illuminance.h"

#include <nlohmann/json.hpp>

#include <string>

namespace penumbra {

// {average_lux, minimum_lux, maximum_lux, uniformity_u0, uniformity_u1}.
nlohmann::json illuminanceStatsJson(const IlluminanceStats& stats);

// One observer's glare: {ugr (null when nothing glares), background_luminance_cd_m2, sources:
// [{name, luminance_cd_m2, solid_angle_sr, position_index, share}]}.
nlohmann::json glareJson(const GlareResult& glare);

// The object's figures (no points): name, type, measure, columns, rows, points, spacing_m,
// rays_per_point, "total" and "direct" {average_lux, minimum_lux, maximum_lux, uniformity_u0,
// uniformity_u1}; a glare object's "observers" (glareJson with position, view, vertical_lux,
// name) and "ugr_max".
nlohmann::json calculationObjectJson(const CalculationGrid& grid, const IlluminanceResult& result);

// The plan view of a plane grid (rows > 1): a cell per point, coloured 0 lx blue to `max_lux`
// red (<= 0: a round number above the maximum), its total lux printed when the cells are large
// enough, the name and figures above, a legend to the right. Display-linear.
Image planViewImage(const CalculationGrid& grid, const IlluminanceResult& result,
                    double max_lux = 0.0);

// Into folder `dir` (made if missing): for object k, NAME.csv, NAME.json and for plane grids
// NAME.png, NAME its name with characters other than letters, digits, '-' and '_' made '_'
// (two objects of one name get -2, -3 ...). Each file is written atomically.
Status writeCalculationReports(const std::string& dir, const IlluminanceReport& report);

}  // namespace penumbra
