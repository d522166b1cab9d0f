// The UGR table of a luminaire by the tabular method of CIE 190:2010, "Calculation and
// presentation of unified glare rating tables for indoor lighting luminaires", from its
// photometric file alone: the values a data sheet prints ("UGR 4H 8H 70/50/20").
//
// The standard room (CIE 190 sec. 4.2): luminaires in a regular grid of spacing S = s H in a
// plane H = 2 m above the observer's eye, which is at the middle of one wall and looks
// horizontally along the room; X is the room's size across the line of sight, Y along it, both
// in multiples of H. A luminaire at R ahead and T across is seen at
//   crosswise (its C0-C180 plane along the line of sight):  C = atan(T / R)          (CIE 117
//   eq. 4.5) endwise   (its C90-C270 plane along it):                C = 90 deg - atan(T / R)
//   (eq. 4.6) gamma = atan(sqrt(R^2 + T^2) / H) (eq. 4.7)
// and gives the term of render/glare_index.h with its intensity I(C, gamma) and projected
// luminous area. Luminaires beyond gamma = 85 deg or outside Guth's table are not counted.
//
// The background luminance is the indirect illuminance on the walls over pi (CIE 190 eq. 7, 8):
//   E_WID = N / A_w (Phi_zL F_T,FW + (Phi_down - Phi_zL) F_T,WW-1 + Phi_up F_T,CW),
//   A_w = 2 H (X + Y), N the number of luminaires,
// with the luminaire's zonal fluxes at the midpoints of 10-degree zones normalised to its flux,
// the flux reaching the floor directly Phi_zL = sum_k F_GL,k Phi_zL,k over the cumulative zonal
// fluxes to 40 + 0.130 of the 40-50 zone, 60, 70 + 0.547 of the 70-80 zone and 90 degrees
// (eq. 9), and the transfer factors F_T of Table 5 (floor to walls, walls to walls less the
// direct part, ceiling to walls) for the reflectances of ceiling, walls and floor cavity. CIE 190
// writes everything per 1000 lm of lamp flux and adds 8 log10(Phi / 1000); with absolute
// intensities and fluxes the correction is built in.
//
// Only the rooms of room index k = X Y / (X + Y) = 2.67 are held: 4H x 8H and 8H x 4H, the
// rooms data sheets quote, with Table 4's F_GL (0.280, 0.165, 0.499, 0.006) and Table 5's F_T
// for k = 2.67, as transcribed in the open implementation 123VincentB/eulumdat-ugr (the other
// room sizes' factors are not available to us).
//
// CIE 190 states its tables for s = 1; catalogues (DIALux, Relux) give UGR at s = 0.25 with the
// same factors, and so does this table by default.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/io/photometry.h"

#include <array>
#include <string>
#include <vector>

namespace penumbra {

// The five reflectance sets of CIE 190 Table 5: ceiling / walls / floor cavity.
struct UgrReflectances {
  double ceiling, walls, floor;
  std::string label() const;  // "70/50/20"
};
inline constexpr std::array<UgrReflectances, 5> kUgrReflectances = {{
    {0.7, 0.5, 0.2},
    {0.7, 0.3, 0.2},
    {0.5, 0.5, 0.2},
    {0.5, 0.3, 0.2},
    {0.3, 0.3, 0.2},
}};

// The zonal flux split of CIE 190 eq. 9-12, lm: downward, upward, and the part of the downward
// flux reaching the floor directly in a room of k = 2.67.
struct UgrZonalFlux {
  double down = 0.0, up = 0.0, floor = 0.0;
};
UgrZonalFlux ugrZonalFlux(const Photometry& photometry);

// The luminaire's flux the tabular method normalises to, lm: the flux the file states, else the
// distribution's integral.
double ugrLuminaireFlux(const Photometry& photometry);

// The standard room: x_h across the line of sight, y_h along it, in multiples of H; luminaires
// at spacing s H.
struct UgrRoom {
  int x_h = 4, y_h = 8;
  double spacing_to_height = 0.25;
};
inline constexpr double kUgrMountingHeight = 2.0;  // H, m

// The luminaires of the room's grid in the observer's frame: R ahead, T across (m).
struct UgrPosition {
  double r, t;
};
std::vector<UgrPosition> ugrLuminairePositions(const UgrRoom& room);

// The sum over the room's luminaires of L^2 omega / p^2, luminaires crosswise or endwise.
double ugrTabularSum(const Photometry& photometry, const UgrRoom& room, bool endwise);

// E_WID, lux, for the luminaire's zonal flux split (ugrZonalFlux) and the reflectance set
// kUgrReflectances[reflectance_set] (CIE 190 eq. 7-8).
double ugrWallIndirectIlluminance(const UgrZonalFlux& flux, const UgrRoom& room,
                                  size_t reflectance_set);

struct UgrTableRow {
  UgrRoom room;
  UgrReflectances reflectances;
  double background_luminance = 0.0;  // cd m^-2
  double crosswise = 0.0, endwise = 0.0;
};

// The table: for 4H x 8H and 8H x 4H, every reflectance set, crosswise and endwise. Refuses a
// spacing outside [0.25, 1] and a file without light below the horizontal.
Expected<std::vector<UgrTableRow>> ugrTable(const Photometry& photometry,
                                            double spacing_to_height = 0.25);

}  // namespace penumbra
