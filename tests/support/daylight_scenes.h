// Scenes lit from outside for the radiosity methods' tests of the sky and the environment
// (radiosity/outside_light.h), built in code as the scene readers would build them.
#pragma once

#include "penumbra/scene/scene.h"

namespace penumbra::test {

// A CIE standard general sky (scene/sky.h) of horizontal illuminance `e_h` (lx) on `scene`, its
// sun at elevation / azimuth (degrees, azimuth clockwise from north, north along +z), and when
// `sun_lux` > 0 its beam as a directional light in scene.lights, as the JSON reader adds it.
void setSky(Scene& scene, int type, double e_h, double sun_elevation_deg, double sun_azimuth_deg,
            double sun_lux, double ground_reflectance);

// A `size` x `size` horizontal square at y = 0 facing up (one-sided), of reflectance `rho`,
// nothing else: under an environment L every point gets pi L, under a sky its E_h.
Scene openPlane(float size, glm::vec3 rho);

// A closed 2 m x 1 m x 1.5 m box of two-sided walls of reflectance `rho`, nothing inside it.
Scene closedBox(glm::vec3 rho);

// A 3 m x 2.5 m x 4 m room (x, y, z; one-sided walls facing in) with a 1.5 m x 1 m glazed window
// in its wall at z = 0 (an opening, clear glass of transmittance 0.878 at normal incidence), a
// 0.6 m two-sided fin left of it outside, under CIE sky 12 (10,000 lx, ground 0.2) with a
// 10,000 lx sun at 35 degrees that shines through the window onto the floor and onto the fin.
// Its camera looks from the window into the room, seeing none of the outside. Without `fin`, the
// same room with nothing outside.
Scene windowRoom(bool fin = true);

}  // namespace penumbra::test
