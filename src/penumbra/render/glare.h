// Discomfort glare at observers in a scene: the Unified Glare Rating of CIE 117-1995 for an eye
// position and a line of sight (render/glare_index.h for the formula and Guth's index),
//   UGR = 8 log10( 0.25 / L_b  sum_i L_i^2 omega_i / p_i^2 ).
//
// - The sources are the scene's own lights, each seen from the eye through a shadow ray:
//   - luminaires: their intensity towards the eye (scene/luminaire.h) over the projected area
//     of the luminous opening their photometric file states; a file without one, point lights
//     and spots are small sources (CIE 146:2002);
//   - emitting surfaces: their luminance, integrated over each triangle by 64 stratified points,
//     each with its own solid angle, position index and shadow ray, gathered per material.
//   Distant (directional) lights and the sky are not glare sources of UGR (daylight glare needs
//   other indices) and are left out.
// - L_b is the indirect illuminance at the eye, facing the line of sight, over pi (CIE 117
//   sec. 4.3): the gather at the eye less the light that arrives straight from the sources
//   (render/illuminance.h). Daylight through openings counts as background.
// - The observer's frame: R along the line of sight, H along the world's up made square to it,
//   T across. Sources behind the eye, below the line of sight or outside Guth's table are not
//   counted.
#pragma once

#include "penumbra/raytrace/ray_engine.h"
#include "penumbra/render/glare_index.h"
#include "penumbra/scene/calculation_grid.h"
#include "penumbra/scene/scene.h"

#include <glm/vec3.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace penumbra {

struct GlareSource {
  std::string name;  // "light 3 (lamp.ldt)", "emitter 'panel'"
  GlareTerm term;    // for a surface: its luminance, visible solid angle and effective p
};

struct GlareResult {
  double ugr = 0.0;                   // NaN when nothing glares (no source in view) or L_b is 0
  double background_luminance = 0.0;  // L_b, cd m^-2
  double sum = 0.0;                   // sum of L^2 omega / p^2
  std::vector<GlareSource> sources;   // those counted, largest term first
};

// UGR for an eye at `eye` looking along `view` (unit, within kMaxViewElevation of horizontal)
// with background luminance `background_luminance`, from the scene's lights and emitting
// surfaces (`flat`, flattenScene(scene)); `seed` for the stratified surface points.
GlareResult glareAt(const Scene& scene, const RayEngine& engine, const FlatTriangles& flat,
                    const glm::dvec3& eye, const glm::dvec3& view, double background_luminance,
                    uint64_t seed);

}  // namespace penumbra
