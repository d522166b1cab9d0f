// The two-band spherical harmonics of subsurface light propagation volumes (Børlum et al. 2011,
// SSLPV, sec. 3 and 4): the basis, the clamped-cosine lobe a virtual point light emits, the
// propagation matrices between neighbouring cells (sec. 4, derived here from their integrals,
// not typed in), the scattering of eq. 3 and the area-light radiance estimate of eq. 5-7.
//
// Basis (sec. 4), in the order c = (c00, c1-1, c10, c11):
//   y00 = 1 / sqrt(4 pi), y1-1 = sqrt(3 / (4 pi)) y, y10 = sqrt(3 / (4 pi)) z,
//   y11 = sqrt(3 / (4 pi)) x    (for a unit direction (x, y, z)).
// A cell holds the radiant intensity I(w) = sum c_i y_i(w) (W sr^-1) of the point light at its
// centre, one coefficient vector per colour channel.
#pragma once

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <array>

namespace penumbra {

// y(w) for a unit direction w.
glm::dvec4 lpvBasis(const glm::dvec3& w);

// The coefficients of max(0, n . w) (n unit): (sqrt(pi) / 2, sqrt(pi / 3) (n_y, n_z, n_x)).
glm::dvec4 lpvCosineLobe(const glm::dvec3& n);

// The flux sqrt(4 pi) c00 of an intensity distribution (W): the l = 1 band integrates to 0.
inline double lpvFlux(const glm::dvec4& c) {
  return 3.5449077018110318 * c.x;
}

// The six axial neighbours: the direction light travels from the source cell into the
// destination, +x, -x, +y, -y, +z, -z.
inline constexpr std::array<glm::ivec3, 6> kLpvDirections = {
    glm::ivec3(1, 0, 0),  glm::ivec3(-1, 0, 0), glm::ivec3(0, 1, 0),
    glm::ivec3(0, -1, 0), glm::ivec3(0, 0, 1),  glm::ivec3(0, 0, -1)};

// Sec. 4: the propagation matrix of direction k (kLpvDirections): the destination's
// coefficients from the source's, sum over the destination's faces f but the one it shares with
// the source of
//   M_f[i][j] = (1 / pi) integral_2pi (n_f . w) y_i(w) dw  *  integral_(dw_f) y_j(w) dw,
// dw_f the solid angle of face f seen from the source cell's centre (the cell width is 1: the
// matrices do not depend on it). The face integrals are computed by Gauss-Legendre quadrature
// over the face (dw = cos / r^2 dA), to 1e-12. glm matrices are column-major: m[j][i] is row i,
// column j.
const std::array<glm::dmat4, 6>& lpvPropagationMatrices();

// Eq. 3: scattering multiplies band l by (1 - s) + s g^l (Henyey-Greenstein moments p_l = g^l),
// s in [0, 1] the dimensionless amount of scattering.
inline glm::dvec4 lpvScatter(const glm::dvec4& c, double s, double g) {
  const double band1 = (1.0 - s) + s * g;
  return glm::dvec4(c.x, c.y * band1, c.z * band1, c.w * band1);
}

// Eq. 5-7 with two bands: the radiance of the uniform area light of cross-section `area` (m^2)
// that emits through a surface of outward unit normal n the flux the cell's point light sends
// into the hemisphere about n: L = (2 / A) (sqrt(1 / (4 pi)) c00 + (1 / 2) sqrt(3 / (4 pi))
// c10^(n)), c10^(n) = n_x c11 + n_y c1-1 + n_z c10 (eq. 6's rotation to the normal's frame).
double lpvAreaLightRadiance(const glm::dvec4& c, const glm::dvec3& n, double area);

}  // namespace penumbra
