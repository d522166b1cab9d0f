// Scenes with textures whose answers have closed forms (tests/raytrace/texture_transport_test.cpp,
// tests/radiosity/texture_radiosity_test.cpp).
#pragma once

#include "penumbra/geometry/chart_atlas.h"
#include "penumbra/scene/scene.h"
#include "support/image_files.h"

#include <glm/vec3.hpp>

#include <memory>
#include <span>

namespace penumbra::test {

// A texture straight from RGBA texels (colour: sRGB-encoded colour; else data).
std::shared_ptr<const Texture> makeTexture(const Rgba8Image& image, bool colour);

// The furnace (a closed cube, every face emitting radiance 1 inwards) with a chequered
// reflectance: 8 x 8 cells per face of 8-bit sRGB codes `dark` and `light` (grey). In a closed
// enclosure the power balance gives the area-mean radiosity pi / (1 - rho_mean) whatever the
// pattern, and every point's irradiance is close to it when the cells are small.
Scene chequeredFurnace(uint8_t dark, uint8_t light);

// A black lattice: 8 x 8 cells of alpha 1 and 0 (half of it covered), in alpha mode `mode`.
Material maskedLattice(AlphaMode mode);

// A floor (y = 0, 4 x 4 m, reflectance 0.5) under a black 2 x 2 m occluder at y = 1 whose
// material is `occluder` (its UVs run over [0, 1]^2), lit by a directional light straight down
// of irradiance `irradiance` (W m^-2).
Scene floorUnderOccluder(const Material& occluder, float irradiance);

// An emitter whose colours come from a texture: 4 x 4 cells of red and green, emission factor
// 3, so its mean radiance is (1.5, 1.5, 0).
Material chequeredScreen();

// A 1 x 1 m emitter facing down at height `height` over a large floor of reflectance 0.5; the
// emitter's material is `emitter` (its UVs run over [0, 1]^2).
Scene emitterOverFloor(const Material& emitter, float height);

// A 1 x 1 m emitter of radiance 10 facing down at y = 2 over a 2 x 2 m `lattice` (black, its UVs
// over [0, 1]^2) at y = 1 over a 4 x 4 m floor of reflectance 0.5: the floor under the lattice
// sees the emitter through its openings only.
Scene emitterOverLattice(const Material& lattice);

// The area-weighted mean red radiosity of the floor's elements under the occluder or lattice
// of floorUnderOccluder and emitterOverLattice (y = 0, |x|, |z| < 1, front faces).
double floorMeanUnder(const ChartAtlas& atlas, std::span<const glm::dvec3> radiosity);

}  // namespace penumbra::test
