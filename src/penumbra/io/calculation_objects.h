// Calculation objects as users describe them (docs/scene-format.md, "Calculation objects"): a
// scene file's "calculation" list, a `--calc` file holding the same list, a `--points` file, and
// the command line's --work-plane and --grid-surface. Every source goes through the same readers
// here, so a value refused in one is refused in all, naming the file and the place.
//
//   {"name": "desks", "type": "work_plane", "height": 0.75, "spacing": 0.25, "margin": 0.5}
//   {"name": "east wall", "type": "grid", "origin": [4, 0, 0], "u": [0, 0, 5], "v": [0, 3, 0],
//    "normal": [-1, 0, 0], "spacing": 0.5, "margin": 0.1}
//   {"name": "desk top", "type": "surface", "mesh": "desk", "spacing": 0.1}
//   {"name": "seats", "type": "points", "measure": "cylindrical",
//    "points": [{"position": [1, 1.2, 2], "name": "A"}, ...]}   (or "file": "seats.csv")
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/scene/calculation_grid.h"
#include "penumbra/scene/scene.h"

#include <nlohmann/json_fwd.hpp>

#include <string>
#include <vector>

namespace penumbra {

// A horizontal work plane facing up, `height` metres above the scene's lowest point, over the
// scene's extent in x and z less `margin` on each side: points at the centres of square cells
// of about `spacing` (the count rounded up so the cells fit the area exactly). Refuses a
// non-positive spacing, an area that the margin leaves empty, and more than 4 million points.
// `file` and `place` name a calculation object in errors (empty: the command line's options).
Expected<CalculationGrid> workPlaneGrid(const Scene& scene, double height, double spacing,
                                        double margin, const std::string& file = "",
                                        const std::string& place = "");

// The front faces of the meshes named `name` (a JSON scene's mesh "name", or a file's own
// mesh names), each triangle split into n^2 similar triangles with n = its longest edge /
// `spacing` rounded up: a point at each one's centroid, facing out of the front, standing for
// its area. Refuses an unknown name (listing the known ones), a bad spacing and more than 4
// million points.
Expected<CalculationGrid> surfaceGrid(const Scene& scene, const std::string& name, double spacing,
                                      const std::string& file = "", const std::string& place = "");

// A rectangle origin + s u + t v (s, t in [0, 1]) less `margin` along its edges, points at the
// centres of cells of about `spacing` (columns along u, rows along v), facing `normal` (unit,
// square to u and v). `file` and `place` name it in errors.
Expected<CalculationGrid> planeGrid(const std::string& name, const glm::dvec3& origin,
                                    const glm::dvec3& u, const glm::dvec3& v,
                                    const glm::dvec3& normal, double spacing, double margin,
                                    const std::string& file, const std::string& place);

// A list of calculation objects (JSON array) from `file` at `place` ("calculation"); relative
// "file"s of points objects are found next to `file`.
Expected<std::vector<CalculationGrid>> calculationObjectsFromJson(const Scene& scene,
                                                                  const nlohmann::json& list,
                                                                  const std::string& file,
                                                                  const std::string& place);

// `--calc FILE`: a JSON file holding the list, or an object {"calculation": [...]}.
Expected<std::vector<CalculationGrid>> readCalculationFile(const Scene& scene,
                                                           const std::string& path);

// `--points FILE`: calculation points from a CSV (x,y,z[,nx,ny,nz[,name]] per line, '#'
// comments, an optional header line; no normal: facing up) or a JSON file (an array of
// {"position": [...], "normal": [...], "name": "..."}, or a points object as above).
Expected<CalculationGrid> readCalculationPoints(const std::string& path);

}  // namespace penumbra
