// Photometric data of luminaires: EULUMDAT (.ldt) and IES LM-63 (.ies, the 1986, 1991, 1995,
// 2002 and 2019 revisions) files, read into one Photometry: the luminous intensity distribution
// in absolute candela on the file's own angle grid (symmetries expanded), the luminaire's stated
// fluxes, its luminous opening, and the intensity in any direction.
//
// Sources for the formats (Penumbra's readers are written from these descriptions):
// - EULUMDAT: A. W. Stockmar, "EULUMDAT - ein Leuchtendatenformat fuer den europaeischen
//   Beleuchtungsplaner", Licht '90, and the line-by-line layout as published by P. Bourke
//   (paulbourke.net/dataformats/ldt) and Lighting Analysts (Photometric Toolbox help, "EULUMDAT
//   file format"); absolute photometry as agreed by DIAL, Lighting Analysts and I. Ashdown
//   ("Handling of absolute photometry data in EULUMDAT files", 2009: negative lamp count, the
//   lamp flux field holds the luminaire's flux).
// - IES: ANSI/IESNA LM-63-02, "Standard File Format for the Electronic Transfer of Photometric
//   Data" (sec. 3 definitions of the photometric types, the keyword and data lines), and
//   I. Ashdown, "Parsing the IESNA LM-63 photometric data file" (1998) for the older revisions.
//
// The luminaire's photometric frame, used by intensity(direction) for every type: gamma = 0 is
// the nadir -z, C = 0 is +x, C = 90 is +y (anticlockwise seen from above):
//   d(C, gamma) = (sin gamma cos C, sin gamma sin C, -cos gamma).
// The length of the luminous opening lies along C0-C180 (x), its width along C90-C270 (y).
#pragma once

#include "penumbra/core/expected.h"

#include <glm/vec3.hpp>

#include <array>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace penumbra {

// The photometric type: which axis the measurement planes share (LM-63-02 sec. 3).
// - kC: the vertical axis. planes = C (horizontal angle, anticlockwise from +x seen from above),
//   angles = gamma (vertical angle from the nadir).
// - kB: a horizontal axis, the luminaire's lateral axis y. planes = H, the angle from the
//   vertical plane through photometric zero towards -y (LM-63 measures type A and B horizontal
//   angles clockwise), a latitude in [-90, 90]; angles = V, the angle of the plane through the
//   y axis, from the nadir (photometric zero, H = V = 0) towards +x (photometric horizontal is
//   H = 0, V = 90):  d(H, V) = (cos H sin V, -sin H, -cos H cos V).
// - kA: the vertical axis, like C, but LM-63 puts photometric zero (the nadir) at V = -90 and
//   photometric horizontal (+x) at H = V = 0: planes = H, a longitude clockwise from +x seen from
//   above, angles = V, the elevation:  d(H, V) = (cos V cos H, -cos V sin H, sin V).
enum class PhotometricType { kC, kB, kA };

// One EULUMDAT lamp set (lines 26a-26f).
struct LampSet {
  int count = 0;       // number of lamps; negative marks absolute photometry
  std::string type;    // type of lamps
  double flux = 0.0;   // total luminous flux of the set's lamps, lm (absolute photometry: the
                       // luminaire's flux)
  std::string colour;  // colour appearance / temperature
  std::string colour_rendering;  // colour rendering group / index
  double watts = 0.0;            // wattage including ballast, W
};

struct Photometry {
  std::string file;    // the name given to the reader
  std::string format;  // "EULUMDAT", "IES LM-63-2002", "IES LM-63-1995", "IES LM-63-1991",
                       // "IES LM-63-1986" (no header line), "IES LM-63-2019"
  std::string manufacturer, luminaire, lamp;  // descriptive strings, as the file has them
  PhotometricType type = PhotometricType::kC;
  // EULUMDAT: Isym 0..4 as stated. IES, derived from the angle ranges: 0 none, 1 rotational
  // (type C, one horizontal angle), 2 mirror about the C0-C180 plane (0..180), 3 about the
  // C90-C270 plane (90..270), 4 about both (0..90); types A and B: 2 when the horizontal angles
  // start at 0 (mirrored to negative H), 3 when the vertical ones do, 4 both.
  int symmetry = 0;

  // The distribution on the file's grid after expanding its symmetry, degrees, strictly
  // ascending. Type C: planes C in [0, 360), wrapping from the last plane to the first (one plane:
  // rotationally symmetric); angles gamma within [0, 180], zero intensity outside their range.
  // Types A and B: planes H, angles V as defined above, zero intensity outside their ranges.
  std::vector<double> planes, angles;
  // planes.size() x angles.size() values, row-major by plane: absolute luminous intensity of the
  // whole luminaire, cd. EULUMDAT: cd/klm x (sum of the lamp sets' flux) / 1000 x conversion
  // factor. IES: candela x multiplier x ballast factor (x ballast-lamp photometric factor before
  // LM-63-2002, where that field became "future use").
  std::vector<double> candela;

  // Fluxes the file states, lm (compare integratedFlux()).
  // stated_flux: EULUMDAT: sum of the lamp sets' flux x LORL / 100 (the luminaire's flux; in
  // absolute photometry the sets' flux is already the luminaire's and LORL is 100). IES relative
  // photometry: lamps x lumens per lamp x ballast factor (x ballast-lamp factor before 2002), the
  // flux of the lamps as operated, which the candela values are normalised to: LM-63 has no field
  // for the luminaire's own flux, so for a luminaire that absorbs light integratedFlux() is this
  // times its efficiency. The candela multiplier is not applied (LM-63 uses it to rescale
  // candela, the lumens field already names the rated lamp). IES absolute photometry (lumens per
  // lamp -1): -1, the file states none.
  double stated_flux = 0.0;
  // Total rated lamp flux: EULUMDAT sum of the sets' flux; IES lamps x lumens per lamp, -1 for
  // absolute photometry.
  double lamp_flux = 0.0;
  double light_output_ratio = 1.0;  // EULUMDAT LORL / 100; 1 for IES
  double watts = 0.0;               // input watts, total (EULUMDAT: sum over the sets)
  // The luminous opening, metres: length along C0-C180 (x), width along C90-C270 (y), height.
  // EULUMDAT: luminous area length/diameter and width (lines 16, 17; width 0 = circular), height
  // the largest of the four C-plane heights (lines 18-21). IES: |width|, |length|, |height| in
  // metres; negative values in the file mark round shapes (circle, ellipse, cylinder, sphere).
  // A round opening has length = width = its diameter (or the ellipse's two axes).
  double length = 0.0, width = 0.0, height = 0.0;
  bool circular = false;  // EULUMDAT luminous width 0; IES a negative width or length
  int lamp_sets = 1;      // EULUMDAT n; 1 for IES

  // EULUMDAT only.
  std::vector<LampSet> lamps;
  double downward_flux_fraction = -1.0;  // DFF / 100; -1 for IES
  double conversion_factor = 1.0;        // line 24
  double measurement_tilt = 0.0;         // line 25, degrees
  std::array<double, 10> direct_ratios{};
  // IES only.
  std::vector<std::pair<std::string, std::string>> keywords;  // "[TEST]" -> value, file order
  double candela_multiplier = 1.0, ballast_factor = 1.0, ballast_lamp_factor = 1.0;
  int lamp_count = 1;  // IES number of lamps
  // TILT=INCLUDE (or a TILT file): LM-63's lamp-to-luminaire geometry (1 lamp vertical, 2 and 3
  // horizontal lamp orientations) and the candela multiplying factor for each tilt angle of the
  // luminaire in use; 0 and empty for TILT=NONE. Not applied to `candela`, which is as measured:
  // a caller tilting the luminaire multiplies by tiltFactor().
  int tilt_geometry = 0;
  std::vector<double> tilt_angles, tilt_factors;

  // Intensity, cd, in the direction (C, gamma) of the photometric frame above (any type;
  // gamma outside [0, 180] is folded back over the pole). Bilinear in the file's grid, wrapping
  // in C for type C; zero outside what the file covers.
  double intensity(double c_degrees, double gamma_degrees) const;
  // The same for a direction in the photometric frame (need not be unit; zero vector: 0).
  double intensity(const glm::dvec3& direction) const;
  // The distribution resampled on a regular type C grid: c_count planes C = 0, dc, ...,
  // 360 - dc (dc = 360 / c_count), each with gamma_count values for gamma = 0 to 180 inclusive;
  // row-major by plane, cd. Needs c_count >= 1 and gamma_count >= 2.
  std::vector<double> resampleC(int c_count, int gamma_count) const;
  // Luminous flux of the distribution, lm: the integral of intensity() over the sphere, exact
  // for the bilinear interpolant on the file's grid (per cell, the corner values times the
  // closed-form integrals of the bilinear weights against sin gamma (type C) or cos of the
  // latitude (A: V, B: H)).
  double integratedFlux() const;
  // The TILT multiplying factor at a tilt angle, degrees, linear between the file's angles and
  // constant beyond them; 1 without tilt data.
  double tiltFactor(double degrees) const;
};

// Readers. Errors are input errors naming the file and "line N" where the problem is.
Expected<Photometry> readEulumdat(const std::string& path);
// A TILT=<file> line is read from that file, relative to the IES file's directory.
Expected<Photometry> readIes(const std::string& path);
// The same from memory (fuzzing, tests); `name` is used in messages. parseIes refuses
// TILT=<file>, having no directory to read it from.
Expected<Photometry> parseEulumdat(std::string_view text, const std::string& name);
Expected<Photometry> parseIes(std::string_view text, const std::string& name);
// By extension: .ldt is EULUMDAT, .ies IES (case-insensitive); other extensions are an input
// error.
Expected<Photometry> readPhotometry(const std::string& path);

}  // namespace penumbra
