// Discomfort glare from luminaires: the Unified Glare Rating of CIE 117-1995, "Discomfort glare
// in interior lighting",
//   UGR = 8 log10( 0.25 / L_b  sum_i L_i^2 omega_i / p_i^2 )                  (CIE 117 eq. 4.1)
// with L_b the background luminance (cd m^-2: the indirect illuminance at the eye over pi),
// L_i the luminance of source i's luminous parts seen from the eye, omega_i their solid angle
// (sr) and p_i Guth's position index of the source's direction.
//
// Small sources (projected luminous area under 0.005 m^2), whose luminance is ill defined, take
// CIE 146:2002's form 200 I^2 / r^2 for L^2 omega. It is the same formula with the projected
// area held at 0.005 m^2 (L^2 omega = I^2 / (A r^2)), so one term serves both, continuously.
//
// The position of a source is taken in the observer's frame (CIE 117 fig. 4.2): R along the line
// of sight, T across it, H above it. Guth's index comes from CIE 117 Table 4.1 (the standard asks
// for the table, not the formulae fitted to it), bilinear between its cells; sources outside it
// (H/R > 1.9, T/R > 3, the blank cells of high H/R near the line of sight) are outside the field
// of view the index covers and are not counted, nor are sources behind the eye or below the
// line of sight.
#pragma once

#include "penumbra/scene/luminaire.h"

#include <cmath>

namespace penumbra {

// Guth's position index p at H/R and T/R (CIE 117 Table 4.1, bilinear), T/R taken as |T|/R; NaN
// outside the table or next to a blank cell.
double guthPositionIndex(double h_over_r, double t_over_r);

// Guth's position index by Levin's fit to Guth's data (IES, 1975), as Radiance's glare tools use
// it, from the angle tau (degrees) between the vertical plane through the line of sight and the
// plane through the line of sight and the source, and sigma (degrees) between the line of sight
// and the source:
//   ln p = (35.2 - 0.31889 tau - 1.22 e^(-2 tau / 9)) 1e-3 sigma
//        + (21 + 0.26667 tau - 0.002963 tau^2) 1e-5 sigma^2.
// For comparison with the table (they differ by up to 11%); UGR uses the table.
double guthPositionIndexLevin(double tau_degrees, double sigma_degrees);

// The area of a luminaire's luminous opening (scene/luminaire.h) projected on the plane square to
// the unit direction (x along C0, y along C90, z along the nadir) from the luminaire towards the
// eye: the bottom face times its cosine and the sides lit by their own cosines,
//   box:      l w max(z, 0) + h (w |x| + l |y|),
//   cylinder: pi l^2 / 4 max(z, 0) + l h sqrt(x^2 + y^2).
double projectedLuminousArea(const LuminousOpening& opening, double x, double y, double z);

// CIE 146:2002's smallest projected area for which L is defined, m^2.
inline constexpr double kSmallSourceArea = 0.005;

// One source's part of the UGR sum, and what it is made of.
struct GlareTerm {
  double luminance = 0.0;       // cd m^-2 (of the area the term uses)
  double solid_angle = 0.0;     // sr
  double position_index = 0.0;  // p; NaN when the source is not counted
  double term = 0.0;            // L^2 omega / p^2; 0 when not counted
  bool counted = false;
};

// A source of intensity `candela` towards the eye with projected luminous area `area` m^2, at R
// ahead, T across and H above the eye (m); `area` below kSmallSourceArea counts as that area.
GlareTerm glareTermOfIntensity(double r_ahead, double t_across, double h_above, double candela,
                               double area);

// A source of known luminance (cd m^-2) filling `solid_angle` sr around the direction (R, T, H).
GlareTerm glareTermOfLuminance(double r_ahead, double t_across, double h_above, double luminance,
                               double solid_angle);

// UGR from the sum of the terms and L_b (cd m^-2); NaN when the sum or L_b is not positive (no
// source in view, or a background without light: UGR has no value).
inline double unifiedGlareRating(double background_luminance, double sum) {
  if (!(sum > 0.0) || !(background_luminance > 0.0)) return std::nan("");
  return 8.0 * std::log10(0.25 / background_luminance * sum);
}

}  // namespace penumbra
