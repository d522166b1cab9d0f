// Photometric files: EULUMDAT symmetries 0-4 expand to the distribution they stand for, IES
// LM-63 revisions, tilt data and horizontal-angle symmetries likewise; types A and B give back a
// distribution written on their grids from a function of the direction; the flux integral is
// exact for the bilinear interpolant; real manufacturers' files integrate to the flux they state;
// malformed files give one error naming the file and the line.
#include "penumbra/io/photometry.h"
#include "support/test_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace penumbra {
namespace {

using test::dataPath;
using test::errorNames;
using test::TempDir;

constexpr double kPi = 3.14159265358979323846;
constexpr double kRad = kPi / 180.0;

// ---------------------------------------------------------------------------------------------
// EULUMDAT files written here. Lines 1-42 of a file with one lamp set, then the values.

std::string ldtHeader(int isym, int mc, double dc, int ng, double dg,
                      const std::string& flux = "1000", const std::string& lorl = "80",
                      const std::string& conversion = "1") {
  std::ostringstream s;
  s << "Penumbra test\n"  // 1 company
    << "1\n"              // 2 Ityp
    << isym << "\n"       // 3 Isym
    << mc << "\n"
    << dc << "\n"
    << ng << "\n"
    << dg << "\n"
    << "report 7\n"                           // 8
    << "Test downlight\n"                     // 9 luminaire name
    << "TD-1\n"                               // 10
    << "td1.ldt\n"                            // 11
    << "2026-12-01/pen\n"                     // 12
    << "600\n300\n80\n"                       // 13-15 luminaire mm
    << "500\n250\n"                           // 16-17 luminous area mm
    << "10\n12\n10\n12\n"                     // 18-21 heights
    << "100\n"                                // 22 DFF
    << lorl << "\n"                           // 23 LORL
    << conversion << "\n"                     // 24
    << "0\n"                                  // 25 tilt
    << "1\n"                                  // 26 n
    << "2\n"                                  // 26a lamps
    << "T16 28W\n"                            // 26b
    << flux << "\n"                           // 26c
    << "3000K\n"                              // 26d
    << "1B\n"                                 // 26e
    << "64\n";                                // 26f
  for (int k = 0; k < 10; ++k) s << "0.5\n";  // 27: direct ratios
  return s.str();
}

std::string joined(const std::vector<double>& v) {
  std::ostringstream s;
  for (double x : v) s << x << "\n";
  return s.str();
}

// The stored plane at angle c: three gamma values (0, 45, 90) distinct for every plane.
std::vector<double> planeValues(double c) {
  return {100.0 + c, 50.0 + c, 10.0 + 0.5 * c};
}

// A file of symmetry `isym` with 8 C planes 0, 45, ..., 315 whose stored planes carry
// planeValues(); flux 1000 lm x conversion 2 makes cd = 2 x cd/klm.
std::string ldtWithPlanes(int isym, const std::vector<double>& stored_c) {
  std::string s = ldtHeader(isym, 8, 45, 3, 45, "1000", "80", "2");
  s += joined({0, 45, 90, 135, 180, 225, 270, 315});
  s += joined({0, 45, 90});
  for (double c : stored_c) s += joined(planeValues(c));
  return s;
}

// Checks that every plane of `p` holds 2 x planeValues(source(C)).
void expectPlanes(const Photometry& p, const std::function<double(double)>& source) {
  ASSERT_EQ(p.planes, (std::vector<double>{0, 45, 90, 135, 180, 225, 270, 315}));
  ASSERT_EQ(p.angles, (std::vector<double>{0, 45, 90}));
  ASSERT_EQ(p.candela.size(), 24u);
  for (size_t i = 0; i < 8; ++i) {
    const std::vector<double> want = planeValues(source(p.planes[i]));
    for (size_t j = 0; j < 3; ++j) {
      EXPECT_DOUBLE_EQ(p.candela[i * 3 + j], 2.0 * want[j]) << "C " << p.planes[i] << " j " << j;
    }
  }
}

TEST(EulumdatSymmetry, Isym0KeepsEveryPlane) {
  auto r = parseEulumdat(ldtWithPlanes(0, {0, 45, 90, 135, 180, 225, 270, 315}), "s0.ldt");
  ASSERT_TRUE(r.ok()) << r.error().describe();
  EXPECT_EQ(r->symmetry, 0);
  expectPlanes(*r, [](double c) { return c; });
}

TEST(EulumdatSymmetry, Isym1CopiesTheOnePlaneToAll) {
  auto r = parseEulumdat(ldtWithPlanes(1, {0}), "s1.ldt");
  ASSERT_TRUE(r.ok()) << r.error().describe();
  EXPECT_EQ(r->symmetry, 1);
  expectPlanes(*r, [](double) { return 0.0; });
}

TEST(EulumdatSymmetry, Isym2MirrorsC0ToC180AcrossTheirPlane) {
  auto r = parseEulumdat(ldtWithPlanes(2, {0, 45, 90, 135, 180}), "s2.ldt");
  ASSERT_TRUE(r.ok()) << r.error().describe();
  // I(C) = I(360 - C).
  expectPlanes(*r, [](double c) { return c <= 180 ? c : 360 - c; });
}

TEST(EulumdatSymmetry, Isym3StoresC270ToC90AndMirrorsAcrossC90C270) {
  // Stored in file order C270, C315, C0, C45, C90 (Mc1 = 3 Mc / 4 + 1 to Mc1 + Mc / 2).
  auto r = parseEulumdat(ldtWithPlanes(3, {270, 315, 0, 45, 90}), "s3.ldt");
  ASSERT_TRUE(r.ok()) << r.error().describe();
  // I(C) = I(180 - C): C135 from C45, C180 from C0, C225 from C315.
  expectPlanes(*r, [](double c) {
    if (c <= 90 || c >= 270) return c;
    return c <= 180 ? 180 - c : 540 - c;
  });
}

TEST(EulumdatSymmetry, Isym4MirrorsTheQuadrantAcrossBothPlanes) {
  auto r = parseEulumdat(ldtWithPlanes(4, {0, 45, 90}), "s4.ldt");
  ASSERT_TRUE(r.ok()) << r.error().describe();
  expectPlanes(*r, [](double c) {
    const double x = c <= 180 ? c : 360 - c;
    return x <= 90 ? x : 180 - x;
  });
}

TEST(EulumdatParse, ReadsTheFieldsAndScalesToAbsoluteCandela) {
  auto r = parseEulumdat(ldtWithPlanes(4, {0, 45, 90}), "fields.ldt");
  ASSERT_TRUE(r.ok()) << r.error().describe();
  const Photometry& p = *r;
  EXPECT_EQ(p.format, "EULUMDAT");
  EXPECT_EQ(p.type, PhotometricType::kC);
  EXPECT_EQ(p.manufacturer, "Penumbra test");
  EXPECT_EQ(p.luminaire, "Test downlight");
  EXPECT_EQ(p.lamp, "T16 28W");
  EXPECT_DOUBLE_EQ(p.lamp_flux, 1000.0);
  EXPECT_DOUBLE_EQ(p.light_output_ratio, 0.8);
  EXPECT_DOUBLE_EQ(p.stated_flux, 800.0);
  EXPECT_DOUBLE_EQ(p.watts, 64.0);
  EXPECT_DOUBLE_EQ(p.conversion_factor, 2.0);
  EXPECT_DOUBLE_EQ(p.length, 0.5);
  EXPECT_DOUBLE_EQ(p.width, 0.25);
  EXPECT_DOUBLE_EQ(p.height, 0.012);
  EXPECT_FALSE(p.circular);
  ASSERT_EQ(p.lamps.size(), 1u);
  EXPECT_EQ(p.lamps[0].count, 2);
  EXPECT_EQ(p.lamps[0].colour, "3000K");
  EXPECT_EQ(p.lamps[0].colour_rendering, "1B");
  EXPECT_DOUBLE_EQ(p.direct_ratios[9], 0.5);
  EXPECT_DOUBLE_EQ(p.downward_flux_fraction, 1.0);
  // cd = cd/klm x 1000 lm / 1000 x conversion factor 2.
  EXPECT_DOUBLE_EQ(p.intensity(0.0, 0.0), 200.0);
}

TEST(EulumdatParse, CommaDecimalsCrlfAndTrailingBlankLines) {
  std::string s = ldtHeader(1, 1, 0, 3, 45, "1250,5", "87,5", "0,5");
  s += "0\n0\n45\n90\n";
  s += "12,5\n  8,25  \n0,5\n\n\n   \n";
  std::string crlf;
  for (char c : s) {
    if (c == '\n') crlf += '\r';
    crlf += c;
  }
  auto r = parseEulumdat(crlf, "comma.ldt");
  ASSERT_TRUE(r.ok()) << r.error().describe();
  EXPECT_DOUBLE_EQ(r->lamp_flux, 1250.5);
  EXPECT_DOUBLE_EQ(r->light_output_ratio, 0.875);
  EXPECT_DOUBLE_EQ(r->stated_flux, 1250.5 * 0.875);
  EXPECT_DOUBLE_EQ(r->conversion_factor, 0.5);
  ASSERT_EQ(r->candela.size(), 3u);
  const double scale = 1250.5 / 1000.0 * 0.5;
  EXPECT_DOUBLE_EQ(r->candela[0], 12.5 * scale);
  EXPECT_DOUBLE_EQ(r->candela[1], 8.25 * scale);
  EXPECT_DOUBLE_EQ(r->candela[2], 0.5 * scale);
  // One plane: the same in every C.
  EXPECT_DOUBLE_EQ(r->intensity(123.0, 45.0), 8.25 * scale);
}

TEST(EulumdatParse, SeveralLampSetsAddTheirFluxAndAbsolutePhotometryKeepsItsFlux) {
  // Two sets: lines 26a-f hold two values each. The second set counts -1 lamps (absolute
  // photometry marks); fluxes add up.
  std::ostringstream s;
  s << "Two sets\n1\n1\n1\n0\n2\n90\nr\nn\nnum\nf\nd\n0\n0\n0\n100\n0\n0\n0\n0\n0\n100\n100\n1\n0\n"
    << "2\n"
    << "1\n-1\n"
    << "LED A\nLED B\n"
    << "600\n400\n"
    << "3000K\n4000K\n"
    << "80\n90\n"
    << "5\n7\n";
  for (int k = 0; k < 10; ++k) s << "0\n";
  s << "0\n0\n90\n100\n50\n";
  auto r = parseEulumdat(s.str(), "two.ldt");
  ASSERT_TRUE(r.ok()) << r.error().describe();
  EXPECT_EQ(r->lamp_sets, 2);
  EXPECT_EQ(r->lamps[1].count, -1);
  EXPECT_EQ(r->lamps[1].type, "LED B");
  EXPECT_DOUBLE_EQ(r->lamp_flux, 1000.0);
  EXPECT_DOUBLE_EQ(r->stated_flux, 1000.0);
  EXPECT_DOUBLE_EQ(r->watts, 12.0);
  EXPECT_DOUBLE_EQ(r->intensity(0.0, 0.0), 100.0);
  EXPECT_TRUE(r->circular);
  EXPECT_DOUBLE_EQ(r->length, 0.1);
  EXPECT_DOUBLE_EQ(r->width, 0.1);
}

TEST(EulumdatParse, SeveralValuesOnALineAfterTheHeaderReadToo) {
  std::string s = ldtHeader(2, 4, 90, 2, 90);
  s += "0 90 180 270\n0 90\n10 5 20 6 30 7\n";
  auto r = parseEulumdat(s, "packed.ldt");
  ASSERT_TRUE(r.ok()) << r.error().describe();
  EXPECT_DOUBLE_EQ(r->intensity(270.0, 0.0), 20.0);  // mirror of C90
  EXPECT_DOUBLE_EQ(r->intensity(180.0, 90.0), 7.0);
}

// ---------------------------------------------------------------------------------------------
// IES files written here.

// A type C file: header, keyword lines, TILT=NONE, the counts and the angles/values as given.
std::string iesC(const std::string& header, const std::vector<double>& vertical,
                 const std::vector<double>& horizontal, const std::vector<double>& candela,
                 const std::string& numbers = "1 1000 1", const std::string& second = "1 1 50") {
  std::ostringstream s;
  if (!header.empty()) s << header << "\n";
  s << "[TEST] T-1\n[MANUFAC] Penumbra Lighting\n[LUMINAIRE] Test fixture\n[LAMP] LED\n"
    << "TILT=NONE\n"
    << numbers << " " << vertical.size() << " " << horizontal.size() << " 1 2 0.2 0.4 0.05\n"
    << second << "\n";
  for (double v : vertical) s << v << " ";
  s << "\n";
  for (double h : horizontal) s << h << " ";
  s << "\n";
  for (size_t k = 0; k < candela.size(); ++k) {
    s << candela[k] << ((k + 1) % vertical.size() == 0 ? "\n" : " ");
  }
  return s.str();
}

// Candela for horizontal angle h and vertical index j: distinct everywhere.
double hValue(double h, size_t j) {
  return 1000.0 + 2.0 * h - 100.0 * double(j);
}

std::vector<double> hTable(const std::vector<double>& horizontal, size_t n_vertical) {
  std::vector<double> out;
  for (double h : horizontal) {
    for (size_t j = 0; j < n_vertical; ++j) out.push_back(hValue(h, j));
  }
  return out;
}

// Checks the planes of `p` and that plane C holds hValue(source(C), j).
void expectHorizontal(const Photometry& p, const std::vector<double>& planes,
                      const std::function<double(double)>& source) {
  ASSERT_EQ(p.planes, planes);
  const size_t na = p.angles.size();
  for (size_t i = 0; i < planes.size(); ++i) {
    for (size_t j = 0; j < na; ++j) {
      EXPECT_DOUBLE_EQ(p.candela[i * na + j], hValue(source(planes[i]), j))
          << "C " << planes[i] << " j " << j;
    }
  }
}

const std::vector<double> kVertical = {0, 30, 60, 90};

TEST(IesSymmetry, OneHorizontalAngleIsRotationallySymmetric) {
  auto r = parseIes(iesC("IESNA:LM-63-2002", kVertical, {0}, hTable({0}, 4)), "rot.ies");
  ASSERT_TRUE(r.ok()) << r.error().describe();
  EXPECT_EQ(r->symmetry, 1);
  expectHorizontal(*r, {0}, [](double) { return 0.0; });
  EXPECT_DOUBLE_EQ(r->intensity(217.0, 30.0), hValue(0, 1));
}

TEST(IesSymmetry, ZeroToNinetyFillsAllFourQuadrants) {
  auto r = parseIes(iesC("IESNA:LM-63-2002", kVertical, {0, 45, 90}, hTable({0, 45, 90}, 4)),
                    "quad.ies");
  ASSERT_TRUE(r.ok()) << r.error().describe();
  EXPECT_EQ(r->symmetry, 4);
  expectHorizontal(*r, {0, 45, 90, 135, 180, 225, 270, 315}, [](double c) {
    const double x = c <= 180 ? c : 360 - c;
    return x <= 90 ? x : 180 - x;
  });
}

TEST(IesSymmetry, ZeroTo180MirrorsAcrossTheC0C180Plane) {
  const std::vector<double> h = {0, 60, 120, 180};
  auto r = parseIes(iesC("IESNA:LM-63-2002", kVertical, h, hTable(h, 4)), "bi.ies");
  ASSERT_TRUE(r.ok()) << r.error().describe();
  EXPECT_EQ(r->symmetry, 2);
  expectHorizontal(*r, {0, 60, 120, 180, 240, 300},
                   [](double c) { return c <= 180 ? c : 360 - c; });
}

TEST(IesSymmetry, NinetyTo270MirrorsAcrossTheC90C270Plane) {
  const std::vector<double> h = {90, 150, 210, 270};
  auto r = parseIes(iesC("IESNA:LM-63-1995", kVertical, h, hTable(h, 4)), "old.ies");
  ASSERT_TRUE(r.ok()) << r.error().describe();
  EXPECT_EQ(r->symmetry, 3);
  // I(C) = I(180 - C): C30 from C150, C330 from C210.
  expectHorizontal(*r, {30, 90, 150, 210, 270, 330}, [](double c) {
    if (c >= 90 && c <= 270) return c;
    return c < 90 ? 180 - c : 540 - c;
  });
}

TEST(IesSymmetry, ZeroTo360KeepsEveryPlaneAndDropsThe360Duplicate) {
  const std::vector<double> h = {0, 90, 180, 270, 360};
  std::vector<double> table = hTable(h, 4);
  auto r = parseIes(iesC("IESNA:LM-63-2002", kVertical, h, table), "full.ies");
  ASSERT_TRUE(r.ok()) << r.error().describe();
  EXPECT_EQ(r->symmetry, 0);
  expectHorizontal(*r, {0, 90, 180, 270}, [](double c) { return c; });
  // Between C270 and C360 = C0 the intensity wraps to plane 0.
  EXPECT_DOUBLE_EQ(r->intensity(315.0, 0.0), 0.5 * (hValue(270, 0) + hValue(0, 0)));
}

TEST(IesSymmetry, OtherHorizontalRangesAreRefusedOnTheLineOfTheAngles) {
  const std::vector<double> h = {0, 20, 45};
  auto r = parseIes(iesC("IESNA:LM-63-2002", kVertical, h, hTable(h, 4)), "odd.ies");
  EXPECT_TRUE(errorNames(r, "odd.ies", "line 10:"));
}

TEST(IesParse, ReadsThe2002FieldsInMetres) {
  auto r =
      parseIes(iesC("IESNA:LM-63-2002", kVertical, {0}, hTable({0}, 4), "2 1500 1.5", "0.9 0.5 42"),
               "f.ies");
  ASSERT_TRUE(r.ok()) << r.error().describe();
  const Photometry& p = *r;
  EXPECT_EQ(p.format, "IES LM-63-2002");
  EXPECT_EQ(p.manufacturer, "Penumbra Lighting");
  EXPECT_EQ(p.luminaire, "Test fixture");
  EXPECT_EQ(p.lamp, "LED");
  ASSERT_GE(p.keywords.size(), 1u);
  EXPECT_EQ(p.keywords[0].first, "[TEST]");
  EXPECT_EQ(p.keywords[0].second, "T-1");
  EXPECT_EQ(p.lamp_count, 2);
  EXPECT_DOUBLE_EQ(p.lamp_flux, 3000.0);
  // 2002: the second field is "future use" and is not applied; ballast factor 0.9 is.
  EXPECT_DOUBLE_EQ(p.stated_flux, 2700.0);
  EXPECT_DOUBLE_EQ(p.ballast_lamp_factor, 1.0);
  EXPECT_DOUBLE_EQ(p.watts, 42.0);
  EXPECT_DOUBLE_EQ(p.width, 0.2);
  EXPECT_DOUBLE_EQ(p.length, 0.4);
  EXPECT_DOUBLE_EQ(p.height, 0.05);
  EXPECT_FALSE(p.circular);
  EXPECT_DOUBLE_EQ(p.intensity(0.0, 0.0), hValue(0, 0) * 1.5 * 0.9);
  EXPECT_EQ(p.tilt_geometry, 0);
  EXPECT_DOUBLE_EQ(p.tiltFactor(30.0), 1.0);
}

TEST(IesParse, Before2002TheBallastLampFactorScalesTheCandela) {
  auto r =
      parseIes(iesC("IESNA:LM-63-1995", kVertical, {0}, hTable({0}, 4), "1 1000 1", "0.9 0.5 42"),
               "f95.ies");
  ASSERT_TRUE(r.ok()) << r.error().describe();
  EXPECT_EQ(r->format, "IES LM-63-1995");
  EXPECT_DOUBLE_EQ(r->ballast_lamp_factor, 0.5);
  EXPECT_DOUBLE_EQ(r->stated_flux, 1000.0 * 0.9 * 0.5);
  EXPECT_DOUBLE_EQ(r->intensity(0.0, 0.0), hValue(0, 0) * 0.45);
}

TEST(IesParse, IesNa91AndHeaderlessLm63_1986) {
  auto r91 = parseIes(iesC("IESNA91", kVertical, {0}, hTable({0}, 4)), "91.ies");
  ASSERT_TRUE(r91.ok()) << r91.error().describe();
  EXPECT_EQ(r91->format, "IES LM-63-1991");
  // 1986: free text lines, no header, no keywords.
  const std::string old =
      "ACME LIGHTING CO. TEST 1234\nRECESSED DOWNLIGHT, 2 LAMPS\nTILT=NONE\n"
      "2 1750 1.0 3 1 1 1 -0.5 -0.5 0.25\n1.0 1.0 60\n0 45 90\n0\n500 300 10\n";
  auto r86 = parseIes(old, "86.ies");
  ASSERT_TRUE(r86.ok()) << r86.error().describe();
  EXPECT_EQ(r86->format, "IES LM-63-1986");
  EXPECT_EQ(r86->luminaire, "ACME LIGHTING CO. TEST 1234");
  EXPECT_DOUBLE_EQ(r86->lamp_flux, 3500.0);
  // Feet, and a circular opening of 0.5 ft.
  EXPECT_TRUE(r86->circular);
  EXPECT_DOUBLE_EQ(r86->width, 0.5 * 0.3048);
  EXPECT_DOUBLE_EQ(r86->length, 0.5 * 0.3048);
  EXPECT_DOUBLE_EQ(r86->height, 0.25 * 0.3048);
  EXPECT_DOUBLE_EQ(r86->intensity(10.0, 45.0), 300.0);
}

TEST(IesParse, NumbersSpanLinesAndCommasSeparateThem) {
  const std::string s =
      "IESNA:LM-63-2002\n[TEST] x\n[MORE] continued\nTILT=NONE\n1,-1,1\n3\n2,1,2,0,0,0,1\n1,\n"
      "10\n0,45\n90 0 180 7,\n6,5 4 3 2\n";
  auto r = parseIes(s, "span.ies");
  ASSERT_TRUE(r.ok()) << r.error().describe();
  EXPECT_EQ(r->keywords[0].second, "x continued");
  EXPECT_DOUBLE_EQ(r->stated_flux, -1.0);  // absolute photometry
  EXPECT_DOUBLE_EQ(r->lamp_flux, -1.0);
  EXPECT_EQ(r->planes, (std::vector<double>{0, 180}));
  EXPECT_DOUBLE_EQ(r->intensity(0.0, 45.0), 6.0);
  EXPECT_DOUBLE_EQ(r->intensity(180.0, 90.0), 2.0);
  EXPECT_DOUBLE_EQ(r->intensity(270.0, 0.0), 0.5 * (4.0 + 7.0));  // between C180 and C360
}

TEST(IesParse, TiltIncludeReadsTheTiltDataBeforeTheCounts) {
  const std::string s =
      "IESNA:LM-63-2002\n[TEST] tilt\nTILT=INCLUDE\n1\n3\n0 45 90\n1.0 0.9 0.6\n"
      "1 1000 1 2 1 1 2 0 0 0\n1 1 10\n0 90\n0\n100 20\n";
  auto r = parseIes(s, "tilt.ies");
  ASSERT_TRUE(r.ok()) << r.error().describe();
  EXPECT_EQ(r->tilt_geometry, 1);
  EXPECT_EQ(r->tilt_angles, (std::vector<double>{0, 45, 90}));
  EXPECT_EQ(r->tilt_factors, (std::vector<double>{1.0, 0.9, 0.6}));
  EXPECT_DOUBLE_EQ(r->tiltFactor(22.5), 0.95);
  EXPECT_DOUBLE_EQ(r->tiltFactor(120.0), 0.6);
  EXPECT_DOUBLE_EQ(r->intensity(0.0, 45.0), 60.0);  // tilt factors are not applied
}

TEST(IesParse, TiltFileIsReadNextToTheIesFileButNotFromMemory) {
  TempDir dir;
  dir.write("lamp.tlt", "2\n2\n0 90\n1 0.5\n");
  const std::string body = "1 1000 1 2 1 1 2 0 0 0\n1 1 10\n0 90\n0\n100 20\n";
  const std::string ies = dir.write("t.ies", "IESNA:LM-63-1995\nTILT=lamp.tlt\n" + body);
  auto r = readIes(ies);
  ASSERT_TRUE(r.ok()) << r.error().describe();
  EXPECT_EQ(r->tilt_geometry, 2);
  EXPECT_DOUBLE_EQ(r->tiltFactor(45.0), 0.75);
  EXPECT_TRUE(errorNames(parseIes("IESNA:LM-63-1995\nTILT=lamp.tlt\n" + body, "mem.ies"), "mem.ies",
                         "line 2:"));
  const std::string missing = dir.write("m.ies", "IESNA:LM-63-1995\nTILT=none.tlt\n" + body);
  EXPECT_TRUE(errorNames(readIes(missing), "m.ies", "line 2:"));
}

TEST(IesParse, UplightOnlyCoversNinetyTo180) {
  auto r = parseIes(iesC("IESNA:LM-63-2002", {90, 135, 180}, {0}, {40, 80, 120}), "up.ies");
  ASSERT_TRUE(r.ok()) << r.error().describe();
  EXPECT_DOUBLE_EQ(r->intensity(0.0, 45.0), 0.0);
  EXPECT_DOUBLE_EQ(r->intensity(0.0, 157.5), 100.0);
  EXPECT_DOUBLE_EQ(r->intensity(glm::dvec3(0, 0, 1)), 120.0);
}

// ---------------------------------------------------------------------------------------------
// Types A and B: LM-63-02 sec. 3. Type B: the planes share the lateral horizontal axis (y);
// photometric zero (H = V = 0) is the nadir, photometric horizontal (H = 0, V = 90) is +x,
// horizontal angles run clockwise (towards -y). Type A: the planes share the vertical axis;
// photometric zero is H = 0, V = -90, photometric horizontal H = V = 0.

glm::dvec3 typeBDirection(double h, double v) {
  return {std::cos(h * kRad) * std::sin(v * kRad), -std::sin(h * kRad),
          -std::cos(h * kRad) * std::cos(v * kRad)};
}
glm::dvec3 typeADirection(double h, double v) {
  return {std::cos(v * kRad) * std::cos(h * kRad), -std::cos(v * kRad) * std::sin(h * kRad),
          std::sin(v * kRad)};
}

// A smooth positive distribution over the sphere; its flux is 400 pi (the linear terms integrate
// to zero).
double smooth(const glm::dvec3& d) {
  return 100.0 + 50.0 * d.x + 30.0 * d.y - 80.0 * d.z;
}

std::vector<double> steps(double from, double to, double step) {
  std::vector<double> out;
  for (double a = from; a <= to + 1e-9; a += step) out.push_back(a);
  return out;
}

// An IES file of type `type` (2 B, 3 A) whose candela at (H, V) are f(direction(H, V)).
std::string iesAB(int type, const std::vector<double>& horizontal,
                  const std::vector<double>& vertical,
                  const std::function<double(const glm::dvec3&)>& f) {
  std::ostringstream s;
  s.precision(17);
  s << "IESNA:LM-63-2002\n[TEST] type " << type << "\nTILT=NONE\n1 -1 1 " << vertical.size() << " "
    << horizontal.size() << " " << type << " 2 0 0 0\n1 1 0\n";
  for (double v : vertical) s << v << " ";
  s << "\n";
  for (double h : horizontal) s << h << " ";
  s << "\n";
  for (double h : horizontal) {
    for (double v : vertical) {
      s << f(type == 2 ? typeBDirection(h, v) : typeADirection(h, v)) << " ";
    }
    s << "\n";
  }
  return s.str();
}

TEST(PhotometryTypeB, AnchorsOfTheFrame) {
  auto r = parseIes(iesAB(2, {-90, 0, 90}, {-180, -90, 0, 90, 180},
                          [](const glm::dvec3& d) { return 10.0 + 3.0 * d.x - 5.0 * d.y - d.z; }),
                    "b.ies");
  ASSERT_TRUE(r.ok()) << r.error().describe();
  ASSERT_EQ(r->type, PhotometricType::kB);
  EXPECT_NEAR(r->intensity(glm::dvec3(0, 0, -1)), 11.0, 1e-9);  // photometric zero: nadir
  EXPECT_NEAR(r->intensity(glm::dvec3(1, 0, 0)), 13.0, 1e-9);   // photometric horizontal
  EXPECT_NEAR(r->intensity(glm::dvec3(0, -1, 0)), 15.0, 1e-9);  // H = 90: -y
  EXPECT_NEAR(r->intensity(glm::dvec3(0, 1, 0)), 5.0, 1e-9);    // H = -90: +y
  EXPECT_NEAR(r->intensity(glm::dvec3(-1, 0, 0)), 7.0, 1e-9);   // V = -90
  EXPECT_NEAR(r->intensity(glm::dvec3(0, 0, 1)), 9.0, 1e-9);    // V = 180
}

TEST(PhotometryTypeA, AnchorsOfTheFrame) {
  auto r = parseIes(iesAB(3, {-180, -90, 0, 90, 180}, {-90, 0, 90},
                          [](const glm::dvec3& d) { return 10.0 + 3.0 * d.x - 5.0 * d.y - d.z; }),
                    "a.ies");
  ASSERT_TRUE(r.ok()) << r.error().describe();
  ASSERT_EQ(r->type, PhotometricType::kA);
  EXPECT_NEAR(r->intensity(glm::dvec3(0, 0, -1)), 11.0, 1e-9);  // V = -90: nadir
  EXPECT_NEAR(r->intensity(glm::dvec3(1, 0, 0)), 13.0, 1e-9);   // H = V = 0
  EXPECT_NEAR(r->intensity(glm::dvec3(0, -1, 0)), 15.0, 1e-9);  // H = 90: -y
  EXPECT_NEAR(r->intensity(glm::dvec3(0, 0, 1)), 9.0, 1e-9);    // V = 90
}

// Directions between the grid points give back the function within the bilinear error.
void expectSmoothBetweenGridPoints(const Photometry& p) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double worst = 0.0;
  for (int k = 0; k < 2000; ++k) {
    glm::dvec3 d(u(rng), u(rng), u(rng));
    const double len = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
    if (len < 0.1 || len > 1.0) continue;
    d /= len;
    worst = std::max(worst, std::abs(p.intensity(d) - smooth(d)));
  }
  // 5-degree cells: the interpolation error of a function varying by ~100 cd per radian is
  // below (5 deg)^2 / 8 x 100 cd ~ 0.1 cd.
  EXPECT_LT(worst, 0.25);
  EXPECT_GT(worst, 1e-4);  // the points are between grid points, not on them
}

TEST(PhotometryTypeB, GivesBackAFunctionOfTheDirection) {
  auto r = parseIes(iesAB(2, steps(-90, 90, 5), steps(-180, 180, 5), smooth), "smooth_b.ies");
  ASSERT_TRUE(r.ok()) << r.error().describe();
  expectSmoothBetweenGridPoints(*r);
  EXPECT_NEAR(r->integratedFlux(), 400.0 * kPi, 400.0 * kPi * 1e-3);
}

TEST(PhotometryTypeA, GivesBackAFunctionOfTheDirection) {
  auto r = parseIes(iesAB(3, steps(-180, 180, 5), steps(-90, 90, 5), smooth), "smooth_a.ies");
  ASSERT_TRUE(r.ok()) << r.error().describe();
  expectSmoothBetweenGridPoints(*r);
  EXPECT_NEAR(r->integratedFlux(), 400.0 * kPi, 400.0 * kPi * 1e-3);
  // The (C, gamma) form agrees with the direction form.
  const double g = 63.0 * kRad, c = 151.0 * kRad;
  EXPECT_DOUBLE_EQ(
      r->intensity(151.0, 63.0),
      r->intensity(glm::dvec3(std::sin(g) * std::cos(c), std::sin(g) * std::sin(c), -std::cos(g))));
}

TEST(PhotometryTypeB, AnglesStartingAtZeroAreMirrored) {
  // No x term: symmetric in V (x -> -x); no y term: symmetric in H (y -> -y).
  auto f = [](const glm::dvec3& d) { return 100.0 - 80.0 * d.z; };
  auto half = parseIes(iesAB(2, steps(0, 90, 5), steps(0, 180, 5), f), "half_b.ies");
  auto full = parseIes(iesAB(2, steps(-90, 90, 5), steps(-180, 180, 5), f), "full_b.ies");
  ASSERT_TRUE(half.ok()) << half.error().describe();
  ASSERT_TRUE(full.ok()) << full.error().describe();
  EXPECT_EQ(half->symmetry, 4);
  EXPECT_EQ(half->planes, full->planes);
  EXPECT_EQ(half->angles, full->angles);
  ASSERT_EQ(half->candela.size(), full->candela.size());
  for (size_t k = 0; k < full->candela.size(); ++k) {
    EXPECT_NEAR(half->candela[k], full->candela[k], 1e-9) << k;
  }
}

TEST(PhotometryTypeA, HorizontalAnglesStartingAtZeroAreMirrored) {
  // Symmetric in y (H -> -H).
  auto f = [](const glm::dvec3& d) { return 100.0 + 50.0 * d.x - 80.0 * d.z; };
  auto half = parseIes(iesAB(3, steps(0, 90, 10), steps(-90, 90, 10), f), "half_a.ies");
  ASSERT_TRUE(half.ok()) << half.error().describe();
  EXPECT_EQ(half->symmetry, 2);
  EXPECT_EQ(half->planes, steps(-90, 90, 10));
  const glm::dvec3 d = typeADirection(-40.0, 20.0);
  EXPECT_NEAR(half->intensity(d), f(d), 1e-9);
  // Behind the luminaire (|H| > 90) the file covers nothing.
  EXPECT_DOUBLE_EQ(half->intensity(glm::dvec3(-1, 0, 0)), 0.0);
}

// ---------------------------------------------------------------------------------------------
// Flux.

Photometry typeCGrid(std::vector<double> planes, std::vector<double> angles,
                     const std::function<double(double, double)>& f) {
  Photometry p;
  p.type = PhotometricType::kC;
  p.planes = std::move(planes);
  p.angles = std::move(angles);
  for (double c : p.planes) {
    for (double g : p.angles) p.candela.push_back(f(c, g));
  }
  return p;
}

TEST(PhotometryFlux, IsotropicThousandCandelaIsFourPiKilolumen) {
  const double want = 4.0 * kPi * 1000.0;
  auto iso = [](double, double) { return 1000.0; };
  EXPECT_NEAR(typeCGrid({0}, steps(0, 180, 5), iso).integratedFlux(), want, want * 1e-6);
  EXPECT_NEAR(typeCGrid(steps(0, 350, 10), {0, 1, 10, 90, 179, 180}, iso).integratedFlux(), want,
              want * 1e-6);
  Photometry a = typeCGrid(steps(-180, 180, 15), steps(-90, 90, 7.5), iso);
  a.type = PhotometricType::kA;
  EXPECT_NEAR(a.integratedFlux(), want, want * 1e-6);
  Photometry b = typeCGrid(steps(-90, 90, 7.5), steps(-180, 180, 15), iso);
  b.type = PhotometricType::kB;
  EXPECT_NEAR(b.integratedFlux(), want, want * 1e-6);
}

TEST(PhotometryFlux, LambertianHemisphereOnAFiveDegreeGridIsPiI0) {
  const double i0 = 1000.0;
  const Photometry p = typeCGrid({0, 90, 180, 270}, steps(0, 90, 5),
                                 [&](double, double g) { return i0 * std::cos(g * kRad); });
  // The exact integral of the piecewise-linear interpolant of cos(gamma) on 5-degree steps is
  // pi I0 (1 - 6.35e-4): linear interpolation of the concave cosine falls short by ~h^2/12.
  const double flux = p.integratedFlux();
  EXPECT_NEAR(flux, kPi * i0, kPi * i0 * 1e-3);
  EXPECT_NEAR(flux / (kPi * i0) - 1.0, -6.351e-4, 1e-6);
}

TEST(PhotometryFlux, ExactForTheBilinearInterpolantOnAnUnevenWrappingGrid) {
  // Uneven planes (the wrap from 300 to 360 + 10 is the widest cell) and gammas; a fine midpoint
  // sum of intensity() over the sphere converges to integratedFlux().
  const Photometry p = typeCGrid({10, 60, 200, 300}, {0, 20, 65, 90, 150, 180},
                                 [](double c, double g) { return 50.0 + c * 0.3 + g * g * 0.01; });
  const int nc = 1440, ng = 1440;
  double sum = 0.0;
  for (int i = 0; i < nc; ++i) {
    const double c = (i + 0.5) * 360.0 / nc;
    for (int j = 0; j < ng; ++j) {
      const double g0 = j * 180.0 / ng, g1 = (j + 1) * 180.0 / ng;
      const double solid = (std::cos(g0 * kRad) - std::cos(g1 * kRad)) * (2.0 * kPi / nc);
      sum += p.intensity(c, 0.5 * (g0 + g1)) * solid;
    }
  }
  EXPECT_NEAR(p.integratedFlux(), sum, sum * 2e-5);
}

TEST(PhotometryFlux, ResampleCIsIntensityOnTheRegularGrid) {
  const Photometry p = typeCGrid({0, 90, 180, 270}, {0, 90, 180},
                                 [](double c, double g) { return c + 1000.0 * (g / 90.0); });
  const std::vector<double> r = p.resampleC(8, 5);
  ASSERT_EQ(r.size(), 40u);
  for (int i = 0; i < 8; ++i) {
    for (int j = 0; j < 5; ++j) EXPECT_DOUBLE_EQ(r[i * 5 + j], p.intensity(45.0 * i, 45.0 * j));
  }
  EXPECT_DOUBLE_EQ(r[1 * 5 + 2], 45.0 + 1000.0);  // C45 between C0 and C90, gamma 90
  EXPECT_DOUBLE_EQ(r[7 * 5 + 0], 0.5 * 270.0);    // C315: halfway from C270 to C360 = C0
}

// ---------------------------------------------------------------------------------------------
// Real manufacturers' files (tests/data/photometry/README.md): the flux integrated from the
// distribution against the flux the file states.

struct RealFile {
  const char* name;
  int symmetry;
  double stated;  // lm
};

TEST(PhotometryRealFiles, EulumdatIntegratesToTheStatedFluxWithinOnePercent) {
  const RealFile files[] = {{"sample_isym1.ldt", 1, 4828.0},
                            {"sample_isym2.ldt", 2, 333.0},
                            {"sample_isym3.ldt", 3, 609.0},
                            {"ledvance_biolux_dn150.ldt", 4, 2000.0}};
  for (const RealFile& f : files) {
    auto r = readPhotometry(dataPath(std::string("photometry/") + f.name));
    ASSERT_TRUE(r.ok()) << r.error().describe();
    EXPECT_EQ(r->format, "EULUMDAT") << f.name;
    EXPECT_EQ(r->symmetry, f.symmetry) << f.name;
    EXPECT_DOUBLE_EQ(r->stated_flux, f.stated) << f.name;
    EXPECT_NEAR(r->integratedFlux(), f.stated, 0.01 * f.stated) << f.name;
  }
}

TEST(PhotometryRealFiles, LedvanceDownlightExpandsItsQuadrant) {
  auto r = readEulumdat(dataPath("photometry/ledvance_biolux_dn150.ldt"));  // CRLF line ends
  ASSERT_TRUE(r.ok()) << r.error().describe();
  const Photometry& p = *r;
  EXPECT_EQ(p.manufacturer, "LEDVANCE GmbH");
  EXPECT_EQ(p.planes.size(), 24u);
  EXPECT_EQ(p.angles.size(), 91u);
  EXPECT_TRUE(p.circular);
  EXPECT_DOUBLE_EQ(p.length, 0.132);
  // 1168.3 cd/klm x 2000 lm at the nadir; C15 gamma 1 is 1168.2 cd/klm, mirrored to C165, C195
  // and C345.
  EXPECT_DOUBLE_EQ(p.intensity(0.0, 0.0), 2336.6);
  for (double c : {15.0, 165.0, 195.0, 345.0}) EXPECT_DOUBLE_EQ(p.intensity(c, 1.0), 2336.4) << c;
}

TEST(PhotometryRealFiles, Bega1995AbsolutePhotometryIntegratesToTheLampLineFlux) {
  auto r = readPhotometry(dataPath("photometry/bega_50988_lm63_1995.ies"));
  ASSERT_TRUE(r.ok()) << r.error().describe();
  const Photometry& p = *r;
  EXPECT_EQ(p.format, "IES LM-63-1995");
  EXPECT_EQ(p.symmetry, 1);
  EXPECT_DOUBLE_EQ(p.stated_flux, -1.0);  // lumens per lamp -1: absolute photometry
  EXPECT_EQ(p.luminaire, "50988.2K3");
  EXPECT_EQ(p.lamp, "1218 lm,14 W");  // the luminaire's flux, stated in the [LAMP] line
  EXPECT_TRUE(p.circular);
  EXPECT_DOUBLE_EQ(p.width, 0.12);
  EXPECT_DOUBLE_EQ(p.intensity(33.0, 0.0), 2225.9);
  EXPECT_NEAR(p.integratedFlux(), 1218.0, 0.01 * 1218.0);
}

TEST(PhotometryRealFiles, AmericanElectric2002BilateralAgreesWithAnIndependentQuadrature) {
  // Relative photometry: the file states the lamp's 13000 lm, not the luminaire's flux (see the
  // README), so the distribution is checked by symmetry and by quadrature instead.
  auto r = readPhotometry(dataPath("photometry/ael_asa_15m_r2_lm63_2002.ies"));
  ASSERT_TRUE(r.ok()) << r.error().describe();
  const Photometry& p = *r;
  EXPECT_EQ(p.format, "IES LM-63-2002");
  EXPECT_EQ(p.symmetry, 2);
  EXPECT_EQ(p.manufacturer, "American Electric Lighting");
  EXPECT_DOUBLE_EQ(p.stated_flux, 13000.0);
  EXPECT_EQ(p.planes.size(), 144u);  // 0, 2.5, ..., 357.5
  EXPECT_DOUBLE_EQ(p.length, 1.24 * 0.3048);
  EXPECT_DOUBLE_EQ(p.intensity(0.0, 0.0), 1666.0);
  EXPECT_DOUBLE_EQ(p.intensity(90.0, 2.5), 1665.0);  // the 37th plane's second value
  EXPECT_DOUBLE_EQ(p.intensity(270.0, 2.5), 1665.0);
  EXPECT_DOUBLE_EQ(p.intensity(0.0, 95.0), 0.0);  // full cutoff: nothing above 90
  const int nc = 720, ng = 720;
  double sum = 0.0;
  for (int i = 0; i < nc; ++i) {
    const double c = (i + 0.5) * 360.0 / nc;
    for (int j = 0; j < ng; ++j) {
      const double g0 = j * 90.0 / ng, g1 = (j + 1) * 90.0 / ng;
      sum += p.intensity(c, 0.5 * (g0 + g1)) * (std::cos(g0 * kRad) - std::cos(g1 * kRad)) *
             (2.0 * kPi / nc);
    }
  }
  const double flux = p.integratedFlux();
  EXPECT_NEAR(flux, sum, 1e-3 * sum);
  // A full-cutoff HID luminaire passes 60-90 % of its lamp's flux (here 73.5 %).
  EXPECT_GT(flux / p.stated_flux, 0.6);
  EXPECT_LT(flux / p.stated_flux, 0.9);
}

// ---------------------------------------------------------------------------------------------
// Malformed input: one error naming the file and the line.

std::string goodLdt() {
  return ldtWithPlanes(4, {0, 45, 90});
}  // 42 header lines + 20 values

std::string replaceLine(const std::string& text, int line, const std::string& with) {
  std::istringstream in(text);
  std::string out, l;
  for (int n = 1; std::getline(in, l); ++n) out += (n == line ? with : l) + "\n";
  return out;
}

// goodLdt() with line `line` replaced by `with`: refused, the error naming the file and that
// line.
bool ldtLineFails(int line, const std::string& with) {
  return errorNames(parseEulumdat(replaceLine(goodLdt(), line, with), "n.ldt"), "n.ldt",
                    "line " + std::to_string(line) + ":");
}

std::string firstLines(const std::string& text, int count) {
  std::istringstream in(text);
  std::string out, l;
  for (int n = 0; n < count && std::getline(in, l); ++n) out += l + "\n";
  return out;
}

TEST(EulumdatErrors, TruncatedFilesNameTheLastLine) {
  EXPECT_TRUE(errorNames(parseEulumdat(firstLines(goodLdt(), 20), "t.ldt"), "t.ldt", "line 20:"));
  // Ends inside the intensities (62 lines in all).
  auto r = parseEulumdat(firstLines(goodLdt(), 60), "t.ldt");
  EXPECT_TRUE(errorNames(r, "t.ldt", "line 60:"));
  EXPECT_NE(r.error().message.find("intensity 8 of 9"), std::string::npos) << r.error().message;
  EXPECT_TRUE(errorNames(parseEulumdat("", "empty.ldt"), "empty.ldt", "line 1:"));
}

TEST(EulumdatErrors, MoreValuesThanTheSymmetryCallsForNameTheFirstExtra) {
  const std::string s = goodLdt() + "7\n8\n";
  EXPECT_TRUE(errorNames(parseEulumdat(s, "extra.ldt"), "extra.ldt", "line 63:"));
}

TEST(EulumdatErrors, NonNumericFieldsNameTheirLine) {
  EXPECT_TRUE(ldtLineFails(4, "eight"));
  EXPECT_TRUE(ldtLineFails(29, "12 lm"));
  EXPECT_TRUE(ldtLineFails(55, "nan"));
  EXPECT_TRUE(ldtLineFails(3, "5"));
}

TEST(EulumdatErrors, AnglesOutOfOrderOrRangeAndNegativeIntensities) {
  // Lines 43-50 C angles, 51-53 gamma angles, 54-62 intensities.
  EXPECT_TRUE(ldtLineFails(52, "0"));
  EXPECT_TRUE(ldtLineFails(50, "360"));
  EXPECT_TRUE(ldtLineFails(57, "-3"));
  EXPECT_TRUE(ldtLineFails(4, "20000"));
  EXPECT_TRUE(ldtLineFails(4, "6"));  // Isym 4 needs a multiple of 4
}

std::string goodIes() {
  return iesC("IESNA:LM-63-2002", kVertical, {0, 90}, hTable({0, 90}, 4));
  // Lines: 1 header, 2-5 keywords, 6 TILT, 7 counts, 8 ballast, 9 vertical, 10 horizontal,
  // 11-12 candela.
}

// goodIes() with line `line` replaced by `with`: refused, the error naming the file and line
// `at`.
bool iesLineFails(int line, const std::string& with, int at) {
  return errorNames(parseIes(replaceLine(goodIes(), line, with), "c.ies"), "c.ies",
                    "line " + std::to_string(at) + ":");
}

TEST(IesErrors, TruncatedAndMissingTilt) {
  auto r = parseIes(firstLines(goodIes(), 11), "t.ies");
  EXPECT_TRUE(errorNames(r, "t.ies", "line 11:"));
  EXPECT_NE(r.error().message.find("candela value 5 of 8"), std::string::npos) << r.error().message;
  EXPECT_TRUE(errorNames(parseIes(firstLines(goodIes(), 5), "t.ies"), "t.ies", "line 5:"));
  EXPECT_TRUE(errorNames(parseIes(firstLines(goodIes(), 7), "t.ies"), "t.ies", "line 7:"));
}

TEST(IesErrors, WrongCounts) {
  // Five vertical angles announced, four given: the horizontal angle 0 comes fifth and is not
  // above 90.
  EXPECT_TRUE(iesLineFails(7, "1 1000 1 5 2 1 2 0.2 0.4 0.05", 10));
  // One horizontal angle announced, two given: the second (line 10) is read as a candela value
  // and the last 5 values, from line 11 on, are left over.
  EXPECT_TRUE(iesLineFails(7, "1 1000 1 4 1 1 2 0.2 0.4 0.05", 11));
  EXPECT_TRUE(iesLineFails(7, "1 1000 1 20000 2 1 2 0 0 0", 7));
  EXPECT_TRUE(iesLineFails(7, "1 1000 1 4 2 4 2 0 0 0", 7));  // photometric type 4
}

TEST(IesErrors, NonNumericNonMonotonicNegativeAndNonFinite) {
  EXPECT_TRUE(iesLineFails(8, "1 1 sixty", 8));
  EXPECT_TRUE(iesLineFails(9, "0 60 30 90", 9));
  EXPECT_TRUE(iesLineFails(12, "1180 1080 -980 880", 12));
  EXPECT_TRUE(iesLineFails(11, "1000 inf 800 700", 11));
  EXPECT_TRUE(iesLineFails(9, "0 30 60 190", 9));
  EXPECT_TRUE(iesLineFails(7, "1 -5 1 4 2 1 2 0 0 0", 7));
}

TEST(PhotometryRead, ByExtensionAndMissingFiles) {
  TempDir dir;
  const std::string ldt = dir.write("UPPER.LDT", goodLdt());
  auto r = readPhotometry(ldt);
  ASSERT_TRUE(r.ok()) << r.error().describe();
  EXPECT_EQ(r->file, ldt);
  EXPECT_TRUE(errorNames(readPhotometry(dir.write("x.txt", goodLdt())), "x.txt", ""));
  EXPECT_TRUE(errorNames(readIes(dir.file("none.ies")), "none.ies", ""));
}

}  // namespace
}  // namespace penumbra
