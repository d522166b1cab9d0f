// Heterogeneous media for subsurface light propagation volumes (Børlum et al. 2011, sec. 3.2 and
// Fig. 9-10: "3D textures" of the extinction, scattering and anisotropy): a medium that varies
// over the translucent mesh's bounding box, given as a grid file or a procedural pattern over a
// homogeneous base (scene/material.h, Subsurface::heterogeneity). The lpv method samples it at
// its cells' centres; the other methods take the base medium.
//
// Grid file (`.pmed`), little-endian:
//   line 1  "penumbra-medium 1"
//   line 2  "NX NY NZ" (each in [1, 512])
//   then NX * NY * NZ records, x fastest, then y, then z, of 7 float32: sigma_a R G B and
//   sigma_s' R G B per millimetre (finite, >= 0) and the Henyey-Greenstein g (in (-1, 1)).
// Sample (i, j, k) sits at the centre of its cell of the box divided NX x NY x NZ; values
// between are interpolated trilinearly (clamped at the box's faces).
#pragma once

#include "penumbra/core/expected.h"

#include <glm/vec3.hpp>

#include <string>
#include <vector>

namespace penumbra {

struct Subsurface;

// The medium at one point: coefficients per metre.
struct MediumSample {
  glm::dvec3 sigma_a{0.0};
  glm::dvec3 sigma_s_prime{0.0};
  double g = 0.0;
};

struct MediumGrid {
  glm::ivec3 size{0};
  std::vector<MediumSample> samples;           // x fastest
  MediumSample at(const glm::dvec3& u) const;  // u in [0, 1]^3 over the box
};

inline constexpr int kMediumGridMaxSide = 512;

// Reads a grid file; errors name the file and the place (the header line, or the sample and
// value), refuse sizes outside [1, 512] before allocating, and truncated or trailing data.
Expected<MediumGrid> readMediumGrid(const std::string& path);
Status writeMediumGrid(const std::string& path, const MediumGrid& grid);

// The procedural patterns by name: "veins" (marble: thin dark veins of 60 times the absorption
// following a turbulent sine, Perlin's classic marble) and "layers" (jade: bands across y of
// 0.3 to 1.7 times the absorption, greener where denser). Empty for another name.
bool isMediumPattern(const std::string& name);
const char* mediumPatternNames();

// The medium of `base` at u in [0, 1]^3 over the mesh's box: its grid if it has one, its
// pattern if it has one, else the base itself.
MediumSample mediumAt(const Subsurface& base, const glm::dvec3& u);

}  // namespace penumbra
