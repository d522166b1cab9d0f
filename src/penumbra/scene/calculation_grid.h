// Calculation objects of lighting design: points where illuminance is measured. They measure
// and are never geometry: no method sees them, they cast no shadow and reflect nothing
// (render/illuminance.h gathers at them once a solution exists).
#pragma once

#include <glm/vec3.hpp>

#include <string>
#include <vector>

namespace penumbra {

// What a calculation point measures: the illuminance on a plane through it facing its normal, or
// the cylindrical illuminance about its normal (the mean vertical illuminance over all directions
// square to the axis, EN 12464-1).
enum class Measure { kPlanar, kCylindrical };

// Calculation points, each with the normal of the surface it measures (the axis for
// cylindrical illuminance).
struct CalculationGrid {
  std::string name;
  // work_plane, grid, surface, points: what made it, for the reports; glare: observers, each
  // point an eye and its normal the line of sight, measuring the vertical illuminance at the eye
  // and UGR (render/glare.h).
  std::string type;
  Measure measure = Measure::kPlanar;
  int columns = 0, rows = 0;  // a plane's points, row-major (rows = 1 for a list)
  std::vector<glm::dvec3> points;
  std::vector<glm::dvec3> normals;
  double spacing = 0.0;  // metres between neighbouring points of a plane
  // The area each point stands for, m^2, when the points are not evenly spread (a surface's);
  // empty: equal shares. The figures' average is weighted by it.
  std::vector<double> areas;
  // Points' own names (a points file's), empty or one per point.
  std::vector<std::string> labels;
  // A plane grid's axes (unit, along its columns and rows), for the plan-view picture.
  glm::dvec3 axis_u{1.0, 0.0, 0.0}, axis_v{0.0, 0.0, 1.0};
};

// A glare observer's line of sight (type "glare", render/glare.h) may rise or fall at most this
// many degrees: nearer the vertical it has no horizon to measure Guth's position index from.
inline constexpr double kMaxViewElevation = 85.0;

// The most calculation points one run takes, all objects together.
inline constexpr size_t kMaxCalculationPoints = 4'000'000;

}  // namespace penumbra
