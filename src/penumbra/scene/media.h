// Translucent media as users give them: Jensen et al. 2001's measured materials by name, a
// medium from its coefficients, or from the colour it shows and how far light travels in it
// (the inverse of the dipole's total reflectance, Jensen and Buhler 2002, sec. 3).
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/scene/material.h"

#include <glm/vec3.hpp>

#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace penumbra {

// The measured materials of Jensen, Marschner, Levoy, Hanrahan 2001 (Fig. 5: sigma_s' and
// sigma_a in mm^-1 for R, G, B; index of refraction 1.3), in metres^-1: "apple", "chicken1",
// "chicken2", "cream", "ketchup", "marble", "potato", "skimmilk", "skin1", "skin2",
// "spectralon", "wholemilk". Empty for another name.
std::optional<Subsurface> subsurfacePreset(std::string_view name);
// The preset names, for messages.
std::span<const char* const> subsurfacePresetNames();

// A medium from its coefficients per millimetre (scaled to metres), refusing what is not a
// medium: negative or non-finite values, a channel without extinction (sigma_s' + sigma_a = 0),
// eta outside [1, 4]. Errors say which value and why; the caller adds the file and place.
Expected<Subsurface> subsurfaceFromCoefficients(const glm::dvec3& sigma_s_prime_per_mm,
                                                const glm::dvec3& sigma_a_per_mm, double eta);

// A medium whose total diffuse reflectance (the dipole's R_d, kernels/dipole.h) is `albedo` and
// whose diffusion length 1 / sigma_tr is `distance` metres, per channel: alpha' from R_d by
// bisection, then sigma_t' = 1 / (distance sqrt(3 (1 - alpha'))). albedo in [0, 1), distance
// > 0.
Expected<Subsurface> subsurfaceFromAlbedo(const glm::dvec3& albedo, const glm::dvec3& distance,
                                          double eta);

// The reflectance of the Lambertian surface that returns as much diffuse light as the medium
// (a semi-infinite slab under uniform light): (1 - F_dr,ext)^2 R_d, where 1 - F_dr,ext is the
// share of diffuse light the boundary lets in (and, by reciprocity, out) and R_d the dipole's
// total diffuse reflectance (kernels/dipole.h). What methods without subsurface transport use in
// a translucent material's place.
glm::dvec3 lambertianAlbedo(const Subsurface& medium);

// Checks a medium already in metres^-1 (as above).
Status checkSubsurface(const Subsurface& medium);

}  // namespace penumbra
