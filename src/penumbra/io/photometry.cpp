// EULUMDAT and IES LM-63 readers and the distribution's evaluation (photometry.h).
//
// Both readers walk the text once. EULUMDAT is line-based up to the direct ratios (one field a
// line, comma or point decimals); from the C angles on its values are read as a stream, so files
// that put several values on a line read too. IES is line-based up to the TILT= line, then a
// stream of numbers separated by whitespace or commas, spanning lines freely. Every value keeps
// the line it is on, for messages. Counts are checked against the values the file still holds
// before anything is allocated for them, and against fixed limits (kMaxAngles, kMaxValues).
#include "penumbra/io/photometry.h"

#include "penumbra/core/check.h"
#include "penumbra/core/file_util.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <functional>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

namespace penumbra {

namespace {

// IES angle ranges per photometric type: vertical lo, hi, horizontal lo, hi (degrees).
constexpr double kRangesC[4] = {0.0, 180.0, 0.0, 360.0};
constexpr double kRangesA[4] = {-90.0, 90.0, -180.0, 180.0};
constexpr double kRangesB[4] = {-180.0, 180.0, -90.0, 90.0};

constexpr double kPi = 3.14159265358979323846;
constexpr double kRadians = kPi / 180.0;
constexpr double kDegrees = 180.0 / kPi;
constexpr double kFeet = 0.3048;  // m
// Limits on what a file may claim: more angles than this per axis, or more intensities in all,
// are refused as absurd (EULUMDAT's own limits are 721 C planes and 361 gamma angles).
constexpr int kMaxAngles = 10000;
constexpr size_t kMaxValues = 4'000'000;
constexpr double kAngleTolerance = 1e-9;  // degrees: angles this close are the same plane
// Absolute intensities above this are refused (searchlights reach 1e9 cd); it keeps every flux
// integral finite.
constexpr double kMaxCandela = 1e12;

// ---------------------------------------------------------------------------------------------
// Text.

bool isSpace(char c) {
  // Ctrl-Z ends some DOS-era files.
  return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f' || c == '\x1a';
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && isSpace(s.front())) s.remove_prefix(1);
  while (!s.empty() && isSpace(s.back())) s.remove_suffix(1);
  return s;
}

std::string_view stripBom(std::string_view text) {
  if (text.size() >= 3 && text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);
  return text;
}

// The text's lines, ends LF, CRLF or CR; a final line end does not start another line.
std::vector<std::string_view> splitLines(std::string_view text) {
  std::vector<std::string_view> lines;
  size_t start = 0;
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '\n' && text[i] != '\r') continue;
    lines.push_back(text.substr(start, i - start));
    if (text[i] == '\r' && i + 1 < text.size() && text[i + 1] == '\n') ++i;
    start = i + 1;
  }
  if (start < text.size()) lines.push_back(text.substr(start));
  return lines;
}

std::string upper(std::string_view s) {
  std::string out(s);
  for (char& c : out) {
    if (c >= 'a' && c <= 'z') c = char(c - 'a' + 'A');
  }
  return out;
}

// A value as it appears in a message: at most 40 characters, unprintable bytes as '?'.
std::string quoted(std::string_view s) {
  std::string out = "'";
  for (size_t i = 0; i < s.size() && i < 40; ++i) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    out += (c >= 32 && c < 127) ? char(c) : '?';
  }
  if (s.size() > 40) out += "...";
  return out + "'";
}

enum class NumberStatus { kOk, kNotNumber, kNotFinite };

// The whole of `s` as a decimal number ("12", "-1.5", ".5", "1e3"); with `comma_decimal`, "12,5"
// is 12.5 (EULUMDAT files written with European settings).
NumberStatus parseNumber(std::string_view s, bool comma_decimal, double& out) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  if (s.empty() || s.front() == '+' || s.size() > 64) return NumberStatus::kNotNumber;
  char buffer[64];
  for (size_t i = 0; i < s.size(); ++i) buffer[i] = (comma_decimal && s[i] == ',') ? '.' : s[i];
  const char* end = buffer + s.size();
  double v = 0.0;
  const auto [ptr, ec] = std::from_chars(buffer, end, v, std::chars_format::general);
  if (ptr != end) return NumberStatus::kNotNumber;
  if (ec == std::errc::result_out_of_range) return NumberStatus::kNotFinite;
  if (ec != std::errc()) return NumberStatus::kNotNumber;
  if (!std::isfinite(v)) return NumberStatus::kNotFinite;
  out = v;
  return NumberStatus::kOk;
}

Error lineError(const std::string& file, size_t line, std::string message) {
  return inputError(file, fmt::format("line {}", line), std::move(message));
}

std::string numberError(std::string_view token, std::string_view what, NumberStatus status) {
  return status == NumberStatus::kNotFinite
             ? fmt::format("{} is not a finite number ({})", quoted(token), what)
             : fmt::format("{} is not a number ({})", quoted(token), what);
}

// ---------------------------------------------------------------------------------------------
// A stream of values, each with its line (1-based).

struct Token {
  std::string_view text;
  size_t line = 0;
};

class TokenStream {
 public:
  // The values on lines[first..] (first 0-based), split at whitespace (and at commas unless
  // `comma_decimal`).
  TokenStream(const std::vector<std::string_view>& lines, size_t first, bool comma_decimal,
              std::string file)
      : comma_decimal_(comma_decimal), file_(std::move(file)), last_line_(lines.size()) {
    for (size_t l = first; l < lines.size(); ++l) {
      const std::string_view line = lines[l];
      size_t i = 0;
      while (i < line.size()) {
        while (i < line.size() && isDelimiter(line[i])) ++i;
        const size_t start = i;
        while (i < line.size() && !isDelimiter(line[i])) ++i;
        if (i > start) tokens_.push_back({line.substr(start, i - start), l + 1});
      }
    }
    if (last_line_ == 0) last_line_ = 1;
  }

  size_t remaining() const { return tokens_.size() - next_; }
  // The line of the value read last (or of the next one before any is read).
  size_t line() const {
    if (next_ > 0) return tokens_[next_ - 1].line;
    return tokens_.empty() ? last_line_ : tokens_.front().line;
  }
  size_t lastLine() const { return last_line_; }
  const std::string& file() const { return file_; }

  // The next value as a finite number; `what` names it in messages.
  Expected<double> number(std::string_view what) {
    if (next_ >= tokens_.size()) {
      return lineError(file_, last_line_, fmt::format("the file ends before {}", what));
    }
    const Token& t = tokens_[next_++];
    double v = 0.0;
    const NumberStatus status = parseNumber(t.text, comma_decimal_, v);
    if (status != NumberStatus::kOk) {
      return lineError(file_, t.line, numberError(t.text, what, status));
    }
    return v;
  }

  // The next value as an integer in [lo, hi] ("3" or "3.0").
  Expected<int> integer(std::string_view what, int lo, int hi) {
    Expected<double> v = number(what);
    if (!v) return v.error();
    if (*v != std::floor(*v) || *v < lo || *v > hi) {
      return lineError(file_, line(),
                       fmt::format("{} must be a whole number from {} to {}, not {}", what, lo, hi,
                                   quoted(tokens_[next_ - 1].text)));
    }
    return static_cast<int>(*v);
  }

  // An error at the value read last.
  Error error(std::string message) const { return lineError(file_, line(), std::move(message)); }

  // Succeeds when every value has been read; otherwise names the first one left over.
  Status end(std::string_view what_was_expected) const {
    if (next_ >= tokens_.size()) return {};
    const Token& t = tokens_[next_];
    return lineError(file_, t.line,
                     fmt::format("{} value(s) left over, starting with {}: the counts do not "
                                 "match the data ({})",
                                 tokens_.size() - next_, quoted(t.text), what_was_expected));
  }

 private:
  bool isDelimiter(char c) const { return isSpace(c) || (!comma_decimal_ && c == ','); }

  std::vector<Token> tokens_;
  size_t next_ = 0;
  bool comma_decimal_;
  std::string file_;
  size_t last_line_;
};

// Reads `count` strictly ascending angles in [lo, hi] ([lo, hi) with `below_hi`).
Status readAngles(TokenStream& in, size_t count, double lo, double hi, std::string_view what,
                  std::vector<double>& out, bool below_hi = false) {
  out.clear();
  out.reserve(count);
  for (size_t k = 0; k < count; ++k) {
    Expected<double> a = in.number(what);
    if (!a) return a.error();
    if (*a < lo || *a > hi || (below_hi && *a == hi)) {
      return in.error(fmt::format("{} {} is outside {} to {} degrees{}", what, *a, lo, hi,
                                  below_hi ? " (exclusive)" : ""));
    }
    if (!out.empty() && *a <= out.back()) {
      return in.error(fmt::format("{}s must increase: {} follows {}", what, *a, out.back()));
    }
    out.push_back(*a);
  }
  return {};
}

// ---------------------------------------------------------------------------------------------
// Grids.

// x's place among ascending xs: xs[i] <= x <= xs[i + 1] with fraction t (i + 1 clamped for a
// single value); false outside [xs.front(), xs.back()] or for NaN.
bool locate(const std::vector<double>& xs, double x, size_t& i, double& t) {
  if (xs.empty() || !(x >= xs.front()) || !(x <= xs.back())) return false;
  if (xs.size() == 1) {
    i = 0;
    t = 0.0;
    return true;
  }
  const size_t hi = size_t(std::upper_bound(xs.begin(), xs.end(), x) - xs.begin());
  if (hi >= xs.size()) {
    i = xs.size() - 2;
    t = 1.0;
    return true;
  }
  i = hi - 1;
  t = (x - xs[i]) / (xs[i + 1] - xs[i]);
  return true;
}

// The row at coordinate x of a table whose rows sit at ascending coordinates xs, linear between
// rows and clamped to the first and last.
void rowAt(const std::vector<double>& xs, const std::vector<double>& values, size_t cols, double x,
           double* out) {
  size_t i = 0;
  double t = 0.0;
  if (!locate(xs, x, i, t)) {
    i = x < xs.front() ? 0 : xs.size() - 1;
    t = 0.0;
  }
  const size_t j = std::min(i + 1, xs.size() - 1);
  for (size_t c = 0; c < cols; ++c) {
    out[c] = values[i * cols + c] * (1.0 - t) + values[j * cols + c] * t;
  }
}

// Sorted, with angles closer than kAngleTolerance merged.
std::vector<double> sortedUnique(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  std::vector<double> out;
  for (double a : v) {
    if (out.empty() || a - out.back() > kAngleTolerance) out.push_back(a);
  }
  return out;
}

// Mirror of a type C plane angle into a half or quadrant the file gives (0 <= c < 360):
// symmetry 2 about the C0-C180 plane (result in [0, 180]), 3 about the C90-C270 plane (result in
// [-90, 90]), 4 about both (result in [0, 90]).
double foldC(double c, int symmetry) {
  switch (symmetry) {
    case 2:
      return c <= 180.0 ? c : 360.0 - c;
    case 3: {
      double x = c > 180.0 ? c - 360.0 : c;  // (-180, 180]
      if (x > 90.0) x = 180.0 - x;
      if (x < -90.0) x = -180.0 - x;
      return x;
    }
    case 4: {
      double x = c <= 180.0 ? c : 360.0 - c;
      return x <= 90.0 ? x : 180.0 - x;
    }
    default:
      return c;
  }
}

// The full table: for each plane in `full`, the stored row at fold(plane), interpolated in the
// stored planes (which sit at the ascending coordinates `stored`).
std::vector<double> expandPlanes(const std::vector<double>& stored,
                                 const std::vector<double>& values, size_t cols,
                                 const std::vector<double>& full,
                                 const std::function<double(double)>& fold) {
  std::vector<double> out(full.size() * cols);
  for (size_t p = 0; p < full.size(); ++p)
    rowAt(stored, values, cols, fold(full[p]), &out[p * cols]);
  return out;
}

// Integrals of the hat functions of the grid xs (radians) against `weight` (sin or cos), exact:
// out[k] = integral of hat_k(x) weight(x) dx over [xs.front(), xs.back()].
enum class Weight { kOne, kSin, kCos };

std::vector<double> hatIntegrals(const std::vector<double>& degrees, Weight weight) {
  std::vector<double> out(degrees.size(), 0.0);
  for (size_t k = 0; k + 1 < degrees.size(); ++k) {
    const double a = degrees[k] * kRadians, b = degrees[k + 1] * kRadians, h = b - a;
    double whole = 0.0, first_moment = 0.0;  // integral of w, and of (x - a) w, over [a, b]
    switch (weight) {
      case Weight::kOne:
        whole = h;
        first_moment = 0.5 * h * h;
        break;
      case Weight::kSin:
        whole = std::cos(a) - std::cos(b);
        first_moment = -h * std::cos(b) + std::sin(b) - std::sin(a);
        break;
      case Weight::kCos:
        whole = std::sin(b) - std::sin(a);
        first_moment = h * std::sin(b) + std::cos(b) - std::cos(a);
        break;
    }
    const double upper = first_moment / h;  // integral of t w, t = (x - a) / h
    out[k] += whole - upper;
    out[k + 1] += upper;
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// EULUMDAT.

struct LdtLines {
  const std::vector<std::string_view>& lines;
  const std::string& file;

  size_t lastLine() const { return std::max<size_t>(lines.size(), 1); }
  Status need(size_t n, std::string_view what) const {
    if (n <= lines.size()) return {};
    return lineError(file, lastLine(), fmt::format("the file ends before line {} ({})", n, what));
  }
  std::string text(size_t n) const {
    return n <= lines.size() ? std::string(trim(lines[n - 1])) : "";
  }
  Status number(size_t n, std::string_view what, double& out) const {
    PENUMBRA_TRY(need(n, what));
    const NumberStatus status = parseNumber(lines[n - 1], true, out);
    if (status != NumberStatus::kOk) {
      return lineError(file, n, numberError(trim(lines[n - 1]), what, status));
    }
    return {};
  }
  Status range(size_t n, std::string_view what, double lo, double hi, double& out) const {
    PENUMBRA_TRY(number(n, what, out));
    if (out < lo || out > hi) {
      return lineError(file, n, fmt::format("{} {} is outside {} to {}", what, out, lo, hi));
    }
    return {};
  }
  Status integer(size_t n, std::string_view what, int lo, int hi, int& out) const {
    double v = 0.0;
    PENUMBRA_TRY(number(n, what, v));
    if (v != std::floor(v) || v < lo || v > hi) {
      return lineError(file, n,
                       fmt::format("{} must be a whole number from {} to {}, not {}", what, lo, hi,
                                   quoted(trim(lines[n - 1]))));
    }
    out = static_cast<int>(v);
    return {};
  }
};

// The counts of lines 2-7 that shape the intensity table.
struct LdtShape {
  int isym = 0, mc = 0, ng = 0;
};

// Lines 13-21: the luminaire's and the luminous area's dimensions; the opening is the luminous
// area's.
Status readLdtOpening(const LdtLines& in, Photometry& p) {
  double dims[9] = {};
  static constexpr std::string_view kDimensions[9] = {"luminaire length/diameter (mm)",
                                                      "luminaire width (mm)",
                                                      "luminaire height (mm)",
                                                      "luminous area length/diameter (mm)",
                                                      "luminous area width (mm)",
                                                      "luminous area height at C0 (mm)",
                                                      "luminous area height at C90 (mm)",
                                                      "luminous area height at C180 (mm)",
                                                      "luminous area height at C270 (mm)"};
  for (size_t k = 0; k < 9; ++k) {
    PENUMBRA_TRY(in.range(13 + k, kDimensions[k], 0.0, 1e9, dims[k]));
  }
  p.length = dims[3] / 1000.0;
  p.width = dims[4] / 1000.0;
  p.height = std::max({dims[5], dims[6], dims[7], dims[8]}) / 1000.0;
  p.circular = dims[4] == 0.0 && dims[3] > 0.0;
  if (p.circular) p.width = p.length;  // the diameter
  return {};
}

// Lines 1-25: the luminaire.
Status readLdtLuminaire(const LdtLines& in, LdtShape& shape, Photometry& p) {
  PENUMBRA_TRY(in.need(1, "company identification"));
  p.manufacturer = in.text(1);
  int ityp = 0;
  PENUMBRA_TRY(in.integer(2, "type indicator Ityp", 0, 3, ityp));
  PENUMBRA_TRY(in.integer(3, "symmetry indicator Isym", 0, 4, shape.isym));
  PENUMBRA_TRY(in.integer(4, "number of C planes Mc", 1, kMaxAngles, shape.mc));
  double dc = 0.0, dg = 0.0;
  PENUMBRA_TRY(in.range(5, "distance between C planes Dc", 0.0, 360.0, dc));
  PENUMBRA_TRY(in.integer(6, "number of intensities per C plane Ng", 2, kMaxAngles, shape.ng));
  PENUMBRA_TRY(in.range(7, "distance between intensities Dg", 0.0, 180.0, dg));
  PENUMBRA_TRY(in.need(12, "date/user"));
  p.luminaire = in.text(9).empty() ? in.text(10) : in.text(9);
  PENUMBRA_TRY(readLdtOpening(in, p));
  double dff = 0.0, lorl = 0.0;
  PENUMBRA_TRY(in.range(22, "downward flux fraction DFF (%)", 0.0, 100.0, dff));
  PENUMBRA_TRY(in.range(23, "light output ratio LORL (%)", 0.0, 100.0, lorl));
  PENUMBRA_TRY(in.number(24, "conversion factor for luminous intensities", p.conversion_factor));
  if (!(p.conversion_factor > 0.0)) {
    return lineError(in.file, 24,
                     fmt::format("the conversion factor for luminous intensities must be "
                                 "positive, not {}",
                                 p.conversion_factor));
  }
  PENUMBRA_TRY(
      in.range(25, "tilt of the luminaire during measurement", -360.0, 360.0, p.measurement_tilt));
  p.downward_flux_fraction = dff / 100.0;
  p.light_output_ratio = lorl / 100.0;
  return {};
}

// Line 26: n lamp sets, then n lines of each of 26a-26f; then the ten direct ratios. The line of
// the first direct ratio.
Expected<size_t> readLdtLampSets(const LdtLines& in, Photometry& p) {
  int n = 0;
  PENUMBRA_TRY(in.integer(26, "number of lamp sets n", 1, 50, n));
  p.lamp_sets = n;
  p.lamps.resize(size_t(n));
  const size_t sets = size_t(n);
  for (size_t s = 0; s < sets; ++s) {
    LampSet& set = p.lamps[s];
    const size_t base = 27 + s;
    PENUMBRA_TRY(in.integer(base, "number of lamps", -100000, 100000, set.count));
    PENUMBRA_TRY(in.need(base + sets, "type of lamps"));
    set.type = in.text(base + sets);
    PENUMBRA_TRY(
        in.range(base + 2 * sets, "total luminous flux of the lamps (lm)", 0.0, 1e12, set.flux));
    PENUMBRA_TRY(in.need(base + 3 * sets, "colour temperature of the lamps"));
    set.colour = in.text(base + 3 * sets);
    PENUMBRA_TRY(in.need(base + 4 * sets, "colour rendering index"));
    set.colour_rendering = in.text(base + 4 * sets);
    PENUMBRA_TRY(in.range(base + 5 * sets, "wattage including ballast (W)", 0.0, 1e12, set.watts));
    p.lamp_flux += set.flux;
    p.watts += set.watts;
  }
  p.lamp = p.lamps.front().type;
  const size_t ratios = 27 + 6 * sets;  // line of the first direct ratio
  for (size_t k = 0; k < 10; ++k) {
    PENUMBRA_TRY(in.number(ratios + k, "direct ratio", p.direct_ratios[k]));
  }
  p.stated_flux = p.lamp_flux * p.light_output_ratio;
  return ratios;
}

// The intensity table as the file stores it: all C and gamma angles, the intensities (cd/klm)
// of the `kept` planes the symmetry keeps, and the factor from cd/klm to cd.
struct LdtTable {
  std::vector<double> c_angles, gammas, stored;
  size_t kept = 0;
  double scale = 1.0;
};

// The intensities of the kept planes, each checked against kMaxCandela once scaled to cd.
Status readLdtIntensities(TokenStream& data, const Photometry& p, LdtTable& table) {
  table.stored.resize(table.kept * table.gammas.size());
  for (size_t k = 0; k < table.stored.size(); ++k) {
    Expected<double> v = data.number("luminous intensity");
    if (!v) return v.error();
    if (*v < 0.0) {
      return data.error(fmt::format("negative luminous intensity {} cd/klm", *v));
    }
    if (!(*v * table.scale <= kMaxCandela)) {
      return data.error(
          fmt::format("luminous intensity {} cd/klm times {} lm / 1000 and the conversion "
                      "factor {} exceeds {:g} cd",
                      *v, p.lamp_flux, p.conversion_factor, kMaxCandela));
    }
    table.stored[k] = *v;
  }
  return {};
}

// The C angles, gamma angles and intensities (cd/klm) of the planes the symmetry keeps:
// Isym 1 one plane; 2 C0..C180 (Mc/2 + 1 planes); 3 C270..C360=C0..C90 (Mc/2 + 1 planes, from
// index 3 Mc/4); 4 C0..C90 (Mc/4 + 1 planes). They follow the last direct ratio (line
// `ratios` + 9) and are read as a stream.
Status readLdtTable(const LdtLines& in, size_t ratios, const LdtShape& shape, const Photometry& p,
                    LdtTable& table) {
  const int isym = shape.isym, mc = shape.mc, ng = shape.ng;
  if ((isym == 2 && mc % 2 != 0) || ((isym == 3 || isym == 4) && mc % 4 != 0)) {
    return lineError(in.file, 4,
                     fmt::format("Mc = {} C planes do not divide into the symmetry Isym = {} "
                                 "(Mc must be a multiple of {})",
                                 mc, isym, isym == 2 ? 2 : 4));
  }
  const size_t mcs = size_t(mc), ngs = size_t(ng);
  const size_t kept = isym == 0 ? mcs : isym == 1 ? 1 : isym == 4 ? mcs / 4 + 1 : mcs / 2 + 1;
  if (mcs * ngs > kMaxValues) {
    return lineError(
        in.file, 6,
        fmt::format("{} C planes of {} intensities are more than {} values", mc, ng, kMaxValues));
  }
  // Enough values must be left before anything is allocated for them.
  TokenStream data(in.lines, std::min(ratios + 9, in.lines.size()), true, in.file);
  if (data.remaining() < mcs + ngs) {
    const size_t have = data.remaining();
    return lineError(
        in.file, data.lastLine(),
        have < mcs ? fmt::format("the file ends before C angle {} of {}", have + 1, mc)
                   : fmt::format("the file ends before gamma angle {} of {}", have - mcs + 1, ng));
  }
  PENUMBRA_TRY(readAngles(data, mcs, 0.0, 360.0, "C angle", table.c_angles, true));
  PENUMBRA_TRY(readAngles(data, ngs, 0.0, 180.0, "gamma angle", table.gammas));
  if (data.remaining() < kept * ngs) {
    return lineError(in.file, data.lastLine(),
                     fmt::format("the file ends before intensity {} of {} (Isym {}: {} planes "
                                 "of {})",
                                 data.remaining() + 1, kept * ngs, isym, kept, ng));
  }
  table.kept = kept;
  table.scale = p.lamp_flux / 1000.0 * p.conversion_factor;  // cd/klm to cd
  if (!std::isfinite(table.scale)) {
    return lineError(in.file, 24, "the lamp flux times the conversion factor overflows");
  }
  PENUMBRA_TRY(readLdtIntensities(data, p, table));
  return data.end(
      fmt::format("Isym {} with Mc {} and Ng {} gives {} intensities", isym, mc, ng, kept * ngs));
}

// The distribution on all Mc planes, in cd: the kept planes unfolded by the symmetry.
Status expandLdtTable(const LdtLines& in, const LdtShape& shape, const LdtTable& table,
                      Photometry& p) {
  const int isym = shape.isym;
  const size_t mcs = table.c_angles.size(), ngs = table.gammas.size(), kept = table.kept;
  // The kept planes' coordinates in the folded domain of foldC (Isym 3: C270.. as -90..).
  std::vector<double> kept_c(kept);
  for (size_t k = 0; k < kept; ++k) {
    const size_t index = isym == 3 ? (3 * mcs / 4 + k) % mcs : k;
    kept_c[k] = table.c_angles[index];
    if (isym == 3 && kept_c[k] > 180.0) kept_c[k] -= 360.0;
    if (k > 0 && kept_c[k] <= kept_c[k - 1]) {
      return lineError(in.file, 4,
                       fmt::format("the C angles do not fit Isym = {}: the planes it keeps are "
                                   "not in order ({} after {})",
                                   isym, table.c_angles[index], kept_c[k - 1]));
    }
  }
  p.symmetry = isym;
  p.planes = table.c_angles;
  p.angles = table.gammas;
  if (isym == 1) {
    p.candela.resize(mcs * ngs);
    for (size_t c = 0; c < mcs; ++c) {
      std::copy(table.stored.begin(), table.stored.end(), &p.candela[c * ngs]);
    }
  } else {
    p.candela = expandPlanes(kept_c, table.stored, ngs, table.c_angles,
                             [isym](double c) { return foldC(c, isym); });
  }
  for (double& v : p.candela) v *= table.scale;
  return {};
}

}  // namespace

Expected<Photometry> parseEulumdat(std::string_view text, const std::string& name) {
  const std::vector<std::string_view> lines = splitLines(stripBom(text));
  const LdtLines in{lines, name};
  Photometry p;
  p.file = name;
  p.format = "EULUMDAT";
  p.type = PhotometricType::kC;
  LdtShape shape;
  PENUMBRA_TRY(readLdtLuminaire(in, shape, p));
  Expected<size_t> ratios = readLdtLampSets(in, p);
  if (!ratios) return ratios.error();
  LdtTable table;
  PENUMBRA_TRY(readLdtTable(in, *ratios, shape, p, table));
  PENUMBRA_TRY(expandLdtTable(in, shape, table, p));
  return p;
}

namespace {

// ---------------------------------------------------------------------------------------------
// IES LM-63.

enum class IesVersion { k1986, k1991, k1995, k2002, k2019 };

// TILT data: geometry, count, angles, factors (LM-63-02 sec. 5.x, the same in a TILT file).
Status readTilt(TokenStream& in, Photometry& p) {
  Expected<int> geometry = in.integer("lamp-to-luminaire geometry", 1, 3);
  if (!geometry) return geometry.error();
  Expected<int> count = in.integer("number of tilt angles", 1, kMaxAngles);
  if (!count) return count.error();
  if (in.remaining() < 2 * size_t(*count)) {
    return lineError(in.file(), in.lastLine(),
                     fmt::format("the file ends before the {} tilt angles and their {} "
                                 "multiplying factors",
                                 *count, *count));
  }
  p.tilt_geometry = *geometry;
  PENUMBRA_TRY(readAngles(in, size_t(*count), 0.0, 180.0, "tilt angle", p.tilt_angles));
  p.tilt_factors.resize(size_t(*count));
  for (double& f : p.tilt_factors) {
    Expected<double> v = in.number("tilt multiplying factor");
    if (!v) return v.error();
    if (*v < 0.0) return in.error(fmt::format("negative tilt multiplying factor {}", *v));
    f = *v;
  }
  return {};
}

using TiltLoader = std::function<Expected<std::string>(const std::string& tilt_name)>;

// The header line: LM-63-1986 files have none. Sets p.format; `line` (the 0-based index of the
// next line) moves past the header line when there is one.
IesVersion readIesVersion(const std::vector<std::string_view>& lines, size_t& line, Photometry& p) {
  IesVersion version = IesVersion::k1986;
  if (!lines.empty()) {
    const std::string head = upper(trim(lines[0]));
    if (head.rfind("IESNA", 0) == 0 || head.rfind("IES:", 0) == 0) {
      line = 1;
      if (head.find("2019") != std::string::npos) {
        version = IesVersion::k2019;
      } else if (head.find("1995") != std::string::npos) {
        version = IesVersion::k1995;
      } else if (head.find("1991") != std::string::npos || head == "IESNA91") {
        version = IesVersion::k1991;
      } else if (head.find("1986") != std::string::npos) {
        version = IesVersion::k1986;
      } else {
        version = IesVersion::k2002;  // LM-63-2002 and unknown later revisions
      }
    }
  }
  static constexpr const char* kFormats[] = {"IES LM-63-1986", "IES LM-63-1991", "IES LM-63-1995",
                                             "IES LM-63-2002", "IES LM-63-2019"};
  p.format = kFormats[int(version)];
  return version;
}

// Keyword lines ("[KEY] value", [MORE] continues the one before; free text in 1986 files) up
// to TILT=, from lines[line] (0-based) on. The 1-based line of TILT=.
Expected<size_t> readIesKeywords(const std::vector<std::string_view>& lines, size_t line,
                                 const std::string& name, Photometry& p, std::string& free_text) {
  size_t tilt_line = 0;  // 1-based
  for (; line < lines.size(); ++line) {
    const std::string_view t = trim(lines[line]);
    const std::string head = upper(t.substr(0, std::min<size_t>(t.size(), 8)));
    if (head.rfind("TILT", 0) == 0 && trim(t.substr(4)).substr(0, 1) == "=") {
      tilt_line = line + 1;
      break;
    }
    if (t.empty()) continue;
    const size_t close = t.find(']');
    if (t.front() == '[' && close != std::string_view::npos) {
      const std::string key = upper(t.substr(1, close - 1));
      const std::string value(trim(t.substr(close + 1)));
      if (key == "MORE" && !p.keywords.empty()) {
        std::string& v = p.keywords.back().second;
        v += v.empty() ? value : " " + value;
      } else {
        p.keywords.emplace_back("[" + key + "]", value);
      }
    } else if (free_text.empty()) {
      free_text = std::string(t);
    }
  }
  if (tilt_line == 0) {
    return lineError(name, std::max<size_t>(lines.size(), 1),
                     "no TILT= line: an LM-63 file names its tilt data (TILT=NONE, "
                     "TILT=INCLUDE or TILT=<file>) before the photometric data");
  }
  return tilt_line;
}

// The value of the first keyword `key` that has one, or "".
std::string keywordValue(const Photometry& p, std::string_view key) {
  for (const auto& [k, v] : p.keywords) {
    if (k == key && !v.empty()) return v;
  }
  return "";
}

// The descriptive strings from the keywords; a 1986 file's free text names the luminaire.
void nameIesLuminaire(const std::string& free_text, Photometry& p) {
  p.manufacturer = keywordValue(p, "[MANUFAC]");
  p.luminaire = keywordValue(p, "[LUMINAIRE]");
  if (p.luminaire.empty()) p.luminaire = keywordValue(p, "[LUMCAT]");
  if (p.luminaire.empty()) p.luminaire = free_text;
  p.lamp = keywordValue(p, "[LAMP]");
  if (p.lamp.empty()) p.lamp = keywordValue(p, "[LAMPCAT]");
}

// The tilt data the TILT= line (1-based `tilt_line`, text `tilt_line_text`) names: none,
// INCLUDE (read from `in`, the numbers after that line), or a separate file `load_tilt` reads.
Status readIesTiltData(std::string_view tilt_line_text, size_t tilt_line,
                       const TiltLoader& load_tilt, TokenStream& in, Photometry& p) {
  const std::string& name = in.file();
  const std::string tilt(trim(tilt_line_text.substr(tilt_line_text.find('=') + 1)));
  const std::string tilt_upper = upper(tilt);
  if (tilt_upper == "INCLUDE") {
    PENUMBRA_TRY(readTilt(in, p));
  } else if (tilt_upper != "NONE") {
    if (tilt.empty()) return lineError(name, tilt_line, "TILT= names no tilt data");
    if (!load_tilt) {
      return lineError(name, tilt_line,
                       fmt::format("TILT={} names a separate tilt file, which a file read from "
                                   "memory cannot open (readIes reads it from the IES file's "
                                   "directory)",
                                   quoted(tilt)));
    }
    Expected<std::string> tilt_text = load_tilt(tilt);
    if (!tilt_text) {
      return lineError(name, tilt_line,
                       fmt::format("TILT={}: {}", quoted(tilt), tilt_text.error().describe()));
    }
    const std::vector<std::string_view> tilt_lines = splitLines(stripBom(*tilt_text));
    TokenStream tilt_in(tilt_lines, 0, false, resolveRelativeTo(name, tilt));
    PENUMBRA_TRY(readTilt(tilt_in, p));
    PENUMBRA_TRY(tilt_in.end("the tilt file's angles and factors"));
  }
  return {};
}

// The two lines of numbers after the tilt data:
// <lamps> <lumens per lamp> <candela multiplier> <vertical angles> <horizontal angles>
// <photometric type> <units> <width> <length> <height>
// <ballast factor> <ballast-lamp photometric factor | future use | file generation type>
// <input watts>
struct IesCounts {
  int lamps = 0;
  double lumens = 0.0, multiplier = 0.0;
  int n_vertical = 0, n_horizontal = 0;
  size_t counts_line = 0;  // the line of the number of horizontal angles
  int type = 0, units = 0;
  double size[3] = {};
  double ballast = 0.0, factor = 0.0;
  bool uses_factor = false;  // the ballast-lamp photometric factor applies (before LM-63-2002)
  double watts = 0.0;
};

// The first line: lamps to height.
Status readIesLampLine(TokenStream& in, IesCounts& c) {
  Expected<int> lamps = in.integer("number of lamps", 1, 1000000);
  if (!lamps) return lamps.error();
  c.lamps = *lamps;
  Expected<double> lumens = in.number("lumens per lamp");
  if (!lumens) return lumens.error();
  if (!(*lumens > 0.0) && *lumens != -1.0) {
    return in.error(
        fmt::format("lumens per lamp must be positive, or -1 for absolute "
                    "photometry, not {}",
                    *lumens));
  }
  c.lumens = *lumens;
  Expected<double> multiplier = in.number("candela multiplier");
  if (!multiplier) return multiplier.error();
  if (!(*multiplier > 0.0)) {
    return in.error(fmt::format("the candela multiplier must be positive, not {}", *multiplier));
  }
  c.multiplier = *multiplier;
  Expected<int> n_vertical = in.integer("number of vertical angles", 2, kMaxAngles);
  if (!n_vertical) return n_vertical.error();
  c.n_vertical = *n_vertical;
  Expected<int> n_horizontal = in.integer("number of horizontal angles", 1, kMaxAngles);
  if (!n_horizontal) return n_horizontal.error();
  c.n_horizontal = *n_horizontal;
  c.counts_line = in.line();
  Expected<int> type = in.integer("photometric type (1 C, 2 B, 3 A)", 1, 3);
  if (!type) return type.error();
  c.type = *type;
  Expected<int> units = in.integer("units type (1 feet, 2 metres)", 1, 2);
  if (!units) return units.error();
  c.units = *units;
  static constexpr std::string_view kSize[3] = {"luminous width", "luminous length",
                                                "luminous height"};
  for (int k = 0; k < 3; ++k) {
    Expected<double> v = in.number(kSize[k]);
    if (!v) return v.error();
    c.size[k] = *v;
  }
  return {};
}

// The second line: ballast factor, the field LM-63-2002 made "future use", input watts.
Status readIesBallastLine(TokenStream& in, IesVersion version, IesCounts& c) {
  Expected<double> ballast = in.number("ballast factor");
  if (!ballast) return ballast.error();
  if (!(*ballast > 0.0)) {
    return in.error(fmt::format("the ballast factor must be positive, not {}", *ballast));
  }
  c.ballast = *ballast;
  Expected<double> factor =
      in.number(version >= IesVersion::k2002 ? std::string_view("future use field")
                                             : std::string_view("ballast-lamp photometric factor"));
  if (!factor) return factor.error();
  c.uses_factor = version < IesVersion::k2002;
  if (c.uses_factor && !(*factor > 0.0)) {
    return in.error(
        fmt::format("the ballast-lamp photometric factor must be positive, not {}", *factor));
  }
  c.factor = *factor;
  Expected<double> watts = in.number("input watts");
  if (!watts) return watts.error();
  if (*watts < 0.0) return in.error(fmt::format("negative input watts {}", *watts));
  c.watts = *watts;
  return {};
}

// The candela table as the file stores it: nv vertical by nh horizontal angles, nh rows of nv
// values, and the factor that makes them absolute.
struct IesTable {
  std::vector<double> vertical, horizontal, values;
  size_t horizontal_line = 0;  // the line of the last horizontal angle
  double scale = 1.0;
};

// The angles, checked against the photometric type's ranges, once their counts are checked
// against kMaxValues and the values the file still holds; sets p.type.
Status readIesAngles(TokenStream& in, const IesCounts& c, Photometry& p, IesTable& table) {
  const size_t nv = size_t(c.n_vertical), nh = size_t(c.n_horizontal);
  if (nv * nh > kMaxValues) {
    return lineError(in.file(), c.counts_line,
                     fmt::format("{} vertical by {} horizontal angles are more than {} candela "
                                 "values",
                                 nv, nh, kMaxValues));
  }
  if (in.remaining() < nv + nh) {
    const size_t have = in.remaining();
    return lineError(
        in.file(), in.lastLine(),
        have < nv
            ? fmt::format("the file ends before vertical angle {} of {}", have + 1, nv)
            : fmt::format("the file ends before horizontal angle {} of {}", have - nv + 1, nh));
  }

  p.type = c.type == 1   ? PhotometricType::kC
           : c.type == 2 ? PhotometricType::kB
                         : PhotometricType::kA;
  // Ranges {vertical lo, hi, horizontal lo, hi}: type C gamma 0..180 and C 0..360; type A a
  // latitude and a longitude; type B a plane angle and a latitude.
  const double(&range)[4] = p.type == PhotometricType::kC   ? kRangesC
                            : p.type == PhotometricType::kA ? kRangesA
                                                            : kRangesB;
  const double v_lo = range[0], v_hi = range[1], h_lo = range[2], h_hi = range[3];
  PENUMBRA_TRY(readAngles(in, nv, v_lo, v_hi, "vertical angle", table.vertical));
  PENUMBRA_TRY(readAngles(in, nh, h_lo, h_hi, "horizontal angle", table.horizontal));
  table.horizontal_line = in.line();
  return {};
}

// The candela values, each checked against kMaxCandela once scaled; none may be left over.
Status readIesCandela(TokenStream& in, const IesCounts& c, IesTable& table) {
  const size_t nv = size_t(c.n_vertical), nh = size_t(c.n_horizontal);
  if (in.remaining() < nv * nh) {
    return lineError(in.file(), in.lastLine(),
                     fmt::format("the file ends before candela value {} of {} ({} horizontal by "
                                 "{} vertical angles, line {})",
                                 in.remaining() + 1, nv * nh, nh, nv, c.counts_line));
  }
  table.scale = c.multiplier * c.ballast * (c.uses_factor ? c.factor : 1.0);
  if (!std::isfinite(table.scale)) {
    return lineError(in.file(), c.counts_line,
                     "the candela multiplier and ballast factors overflow");
  }
  table.values.resize(nv * nh);
  for (double& v : table.values) {
    Expected<double> value = in.number("candela value");
    if (!value) return value.error();
    if (*value < 0.0) return in.error(fmt::format("negative candela value {}", *value));
    if (!(*value * table.scale <= kMaxCandela)) {
      return in.error(
          fmt::format("candela value {} times the multiplier and ballast factors exceeds {:g} cd",
                      *value, kMaxCandela));
    }
    v = *value;
  }
  return in.end(fmt::format("{} horizontal by {} vertical angles (line {}) give {} candela values",
                            nh, nv, c.counts_line, nv * nh));
}

// Type C: the horizontal angles' range gives the symmetry, expanded to planes in [0, 360).
Status expandIesTypeC(const IesTable& table, const std::string& name, Photometry& p) {
  const std::vector<double>& horizontal = table.horizontal;
  const size_t nv = table.vertical.size(), nh = horizontal.size();
  const double first = horizontal.front(), last = horizontal.back();
  std::vector<double> full;
  int symmetry = 0;
  if (nh == 1) {
    symmetry = 1;
    full = {0.0};
  } else if (first == 0.0 && last == 90.0) {
    symmetry = 4;
    for (double h : horizontal) full.insert(full.end(), {h, 180.0 - h, 180.0 + h, 360.0 - h});
  } else if (first == 0.0 && last == 180.0) {
    symmetry = 2;
    for (double h : horizontal) full.insert(full.end(), {h, 360.0 - h});
  } else if (first == 90.0 && last == 270.0) {
    symmetry = 3;
    for (double h : horizontal) {
      full.push_back(h);
      full.push_back(h <= 180.0 ? 180.0 - h : 540.0 - h);
    }
  } else if (first == 0.0 && last > 180.0) {
    full = horizontal;  // 0 to 360, or to a last plane short of 360 that wraps to 0
  } else {
    return lineError(name, table.horizontal_line,
                     fmt::format("type C horizontal angles {} to {}: LM-63 allows 0 alone "
                                 "(rotational symmetry), 0 to 90, 0 to 180, 90 to 270, or 0 "
                                 "to more than 180 (up to 360)",
                                 first, last));
  }
  std::vector<double> planes;
  for (double c : sortedUnique(std::move(full))) {
    if (c < 360.0 - kAngleTolerance) planes.push_back(c);  // C = 360 is C = 0
  }
  p.symmetry = symmetry;
  p.angles = table.vertical;
  if (symmetry == 1) {
    p.planes = planes;
    p.candela = table.values;
  } else {
    // 90..270 is read as its own domain: mirror C into [90, 270].
    auto fold = [symmetry](double c) {
      if (symmetry != 3) return foldC(c, symmetry);
      if (c >= 90.0 && c <= 270.0) return c;
      return c < 90.0 ? 180.0 - c : 540.0 - c;
    };
    p.candela = expandPlanes(horizontal, table.values, nv, planes, fold);
    p.planes = std::move(planes);
  }
  return {};
}

// Types A and B: an axis starting at 0 is mirrored to negative angles.
Status expandIesTypesAB(const IesTable& table, const std::string& name, Photometry& p) {
  const std::vector<double>&vertical = table.vertical, &horizontal = table.horizontal;
  const size_t nv = vertical.size(), nh = horizontal.size();
  const bool mirror_h = horizontal.front() == 0.0 && nh > 1;
  const bool mirror_v = vertical.front() == 0.0;
  auto mirrored = [](const std::vector<double>& a) {
    std::vector<double> out;
    for (size_t k = a.size(); k-- > 1;) out.push_back(-a[k]);
    out.insert(out.end(), a.begin(), a.end());
    return out;
  };
  if (nh < 2 && !mirror_h) {
    return lineError(name, table.horizontal_line,
                     "types A and B need at least two horizontal angles");
  }
  p.planes = mirror_h ? mirrored(horizontal) : horizontal;
  p.angles = mirror_v ? mirrored(vertical) : vertical;
  const size_t np = p.planes.size(), na = p.angles.size();
  p.candela.resize(np * na);
  for (size_t i = 0; i < np; ++i) {
    const size_t si = mirror_h ? (i < nh - 1 ? nh - 1 - i : i - (nh - 1)) : i;
    for (size_t j = 0; j < na; ++j) {
      const size_t sj = mirror_v ? (j < nv - 1 ? nv - 1 - j : j - (nv - 1)) : j;
      p.candela[i * na + j] = table.values[si * nv + sj];
    }
  }
  p.symmetry = mirror_h && mirror_v ? 4 : mirror_h ? 2 : mirror_v ? 3 : 0;
  return {};
}

// The opening in metres, the factors and the stated fluxes.
void setIesOpeningAndFluxes(const IesCounts& c, Photometry& p) {
  const double metres = c.units == 1 ? kFeet : 1.0;
  p.width = std::abs(c.size[0]) * metres;
  p.length = std::abs(c.size[1]) * metres;
  p.height = std::abs(c.size[2]) * metres;
  // Negative width or length: a round opening (LM-63-02 gives circles as width = length < 0;
  // older files write the diameter as a negative width and a zero length).
  p.circular = c.size[0] < 0.0 || c.size[1] < 0.0;
  if (p.circular && p.width == 0.0) p.width = p.length;
  if (p.circular && p.length == 0.0) p.length = p.width;
  p.lamp_count = c.lamps;
  p.candela_multiplier = c.multiplier;
  p.ballast_factor = c.ballast;
  p.ballast_lamp_factor = c.uses_factor ? c.factor : 1.0;
  p.watts = c.watts;
  p.lamp_sets = 1;
  p.light_output_ratio = 1.0;
  const double operated = p.ballast_factor * p.ballast_lamp_factor;
  if (c.lumens < 0.0) {
    p.lamp_flux = -1.0;
    p.stated_flux = -1.0;
  } else {
    p.lamp_flux = c.lamps * c.lumens;
    p.stated_flux = p.lamp_flux * operated;
  }
}

Expected<Photometry> parseIesWith(std::string_view text, const std::string& name,
                                  const TiltLoader& load_tilt) {
  const std::vector<std::string_view> lines = splitLines(stripBom(text));
  Photometry p;
  p.file = name;
  size_t line = 0;  // 0-based index of the next line
  const IesVersion version = readIesVersion(lines, line, p);
  std::string free_text;
  Expected<size_t> tilt_line = readIesKeywords(lines, line, name, p, free_text);
  if (!tilt_line) return tilt_line.error();
  nameIesLuminaire(free_text, p);

  // The tilt data and the photometric data: numbers from the line after TILT= on.
  TokenStream in(lines, *tilt_line, false, name);
  PENUMBRA_TRY(readIesTiltData(trim(lines[*tilt_line - 1]), *tilt_line, load_tilt, in, p));
  IesCounts counts;
  PENUMBRA_TRY(readIesLampLine(in, counts));
  PENUMBRA_TRY(readIesBallastLine(in, version, counts));
  IesTable table;
  PENUMBRA_TRY(readIesAngles(in, counts, p, table));
  PENUMBRA_TRY(readIesCandela(in, counts, table));

  // Expand the symmetry.
  if (p.type == PhotometricType::kC) {
    PENUMBRA_TRY(expandIesTypeC(table, name, p));
  } else {
    PENUMBRA_TRY(expandIesTypesAB(table, name, p));
  }

  // Units, scale and the stated fluxes.
  setIesOpeningAndFluxes(counts, p);
  for (double& v : p.candela) v *= table.scale;
  return p;
}

}  // namespace

Expected<Photometry> parseIes(std::string_view text, const std::string& name) {
  return parseIesWith(text, name, nullptr);
}

Expected<Photometry> readEulumdat(const std::string& path) {
  Expected<std::string> text = readFile(path);
  if (!text) return text.error();
  return parseEulumdat(*text, path);
}

Expected<Photometry> readIes(const std::string& path) {
  Expected<std::string> text = readFile(path);
  if (!text) return text.error();
  return parseIesWith(*text, path, [&path](const std::string& tilt_name) {
    return readFile(resolveRelativeTo(path, tilt_name));
  });
}

Expected<Photometry> readPhotometry(const std::string& path) {
  const std::string ext = extensionOf(path);
  if (ext == ".ldt") return readEulumdat(path);
  if (ext == ".ies") return readIes(path);
  return inputError(path, "",
                    fmt::format("unknown photometric file type {} (expected .ldt for EULUMDAT "
                                "or .ies for IES LM-63)",
                                ext.empty() ? std::string("(no extension)") : quoted(ext)));
}

// ---------------------------------------------------------------------------------------------
// Evaluation.

namespace {

void checkShape(const Photometry& p) {
  PENUMBRA_CHECK_MSG(!p.planes.empty() && !p.angles.empty() &&
                         p.candela.size() == p.planes.size() * p.angles.size(),
                     "{} planes, {} angles, {} candela values", p.planes.size(), p.angles.size(),
                     p.candela.size());
}

// Bilinear in (planes, angles), zero outside both ranges (types A and B).
double bilinear(const Photometry& p, double plane, double angle) {
  size_t i = 0, j = 0;
  double s = 0.0, t = 0.0;
  if (!locate(p.planes, plane, i, s) || !locate(p.angles, angle, j, t)) return 0.0;
  const size_t na = p.angles.size();
  const size_t i1 = std::min(i + 1, p.planes.size() - 1), j1 = std::min(j + 1, na - 1);
  const double* a = &p.candela[i * na];
  const double* b = &p.candela[i1 * na];
  return (1.0 - s) * ((1.0 - t) * a[j] + t * a[j1]) + s * ((1.0 - t) * b[j] + t * b[j1]);
}

// Type C: gamma in [0, 180], any C; wraps in C.
double intensityC(const Photometry& p, double c, double gamma) {
  size_t j = 0;
  double t = 0.0;
  if (!locate(p.angles, gamma, j, t)) return 0.0;
  const size_t na = p.angles.size(), j1 = std::min(j + 1, na - 1);
  auto at = [&](size_t plane) {
    const double* row = &p.candela[plane * na];
    return (1.0 - t) * row[j] + t * row[j1];
  };
  const size_t np = p.planes.size();
  if (np == 1) return at(0);
  c = std::fmod(c, 360.0);
  if (c < 0.0) c += 360.0;
  size_t i = 0;
  double s = 0.0;
  if (c >= p.planes.front() && c <= p.planes.back()) {
    locate(p.planes, c, i, s);
    return (1.0 - s) * at(i) + s * at(i + 1);
  }
  // Between the last plane and the first one past 360.
  const double span = p.planes.front() + 360.0 - p.planes.back();
  const double from_last = c > p.planes.back() ? c - p.planes.back() : c + 360.0 - p.planes.back();
  s = std::clamp(from_last / span, 0.0, 1.0);
  return (1.0 - s) * at(np - 1) + s * at(0);
}

}  // namespace

double Photometry::intensity(const glm::dvec3& d) const {
  checkShape(*this);
  const double r = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
  if (!(r > 0.0) || !std::isfinite(r)) return 0.0;
  const glm::dvec3 u = d / r;
  switch (type) {
    case PhotometricType::kC:
      return intensityC(*this, std::atan2(u.y, u.x) * kDegrees,
                        std::acos(std::clamp(-u.z, -1.0, 1.0)) * kDegrees);
    case PhotometricType::kA:
      // d = (cos V cos H, -cos V sin H, sin V).
      return bilinear(*this, std::atan2(-u.y, u.x) * kDegrees,
                      std::asin(std::clamp(u.z, -1.0, 1.0)) * kDegrees);
    case PhotometricType::kB:
      // d = (cos H sin V, -sin H, -cos H cos V).
      return bilinear(*this, std::asin(std::clamp(-u.y, -1.0, 1.0)) * kDegrees,
                      std::atan2(u.x, -u.z) * kDegrees);
  }
  return 0.0;
}

double Photometry::intensity(double c_degrees, double gamma_degrees) const {
  checkShape(*this);
  if (!std::isfinite(c_degrees) || !std::isfinite(gamma_degrees)) return 0.0;
  // Fold gamma into [0, 180]: past a pole the direction lies in the opposite half plane.
  double gamma = std::fmod(gamma_degrees, 360.0);
  if (gamma < 0.0) gamma += 360.0;
  double c = c_degrees;
  if (gamma > 180.0) {
    gamma = 360.0 - gamma;
    c += 180.0;
  }
  if (type == PhotometricType::kC) return intensityC(*this, c, gamma);
  const double g = gamma * kRadians, cr = c * kRadians;
  return intensity(
      glm::dvec3(std::sin(g) * std::cos(cr), std::sin(g) * std::sin(cr), -std::cos(g)));
}

std::vector<double> Photometry::resampleC(int c_count, int gamma_count) const {
  PENUMBRA_CHECK_MSG(c_count >= 1 && gamma_count >= 2, "c_count {}, gamma_count {}", c_count,
                     gamma_count);
  std::vector<double> out(size_t(c_count) * size_t(gamma_count));
  for (int i = 0; i < c_count; ++i) {
    const double c = 360.0 * i / c_count;
    for (int j = 0; j < gamma_count; ++j) {
      out[size_t(i) * size_t(gamma_count) + size_t(j)] =
          intensity(c, 180.0 * j / (gamma_count - 1));
    }
  }
  return out;
}

double Photometry::integratedFlux() const {
  checkShape(*this);
  // The bilinear interpolant is a sum of products of hat functions, so its integral against the
  // solid angle element is a sum of corner values times products of one-dimensional integrals.
  std::vector<double> plane_weights, angle_weights;
  switch (type) {
    case PhotometricType::kC: {
      // dOmega = sin(gamma) dgamma dC; C wraps, so each plane takes half of each neighbouring
      // interval (a single plane, the whole circle).
      const size_t np = planes.size();
      plane_weights.assign(np, 2.0 * kPi);
      if (np > 1) {
        for (size_t i = 0; i < np; ++i) {
          const double next = i + 1 < np ? planes[i + 1] : planes[0] + 360.0;
          const double prev = i > 0 ? planes[i - 1] : planes[np - 1] - 360.0;
          plane_weights[i] = 0.5 * (next - prev) * kRadians;
        }
      }
      angle_weights = hatIntegrals(angles, Weight::kSin);
      break;
    }
    case PhotometricType::kA:  // H longitude, V latitude: dOmega = cos V dV dH
      plane_weights = hatIntegrals(planes, Weight::kOne);
      angle_weights = hatIntegrals(angles, Weight::kCos);
      break;
    case PhotometricType::kB:  // H latitude, V plane angle: dOmega = cos H dH dV
      plane_weights = hatIntegrals(planes, Weight::kCos);
      angle_weights = hatIntegrals(angles, Weight::kOne);
      break;
  }
  const size_t na = angles.size();
  double flux = 0.0;
  for (size_t i = 0; i < planes.size(); ++i) {
    double row = 0.0;
    for (size_t j = 0; j < na; ++j) row += candela[i * na + j] * angle_weights[j];
    flux += plane_weights[i] * row;
  }
  return flux;
}

double Photometry::tiltFactor(double degrees) const {
  if (tilt_angles.empty() || tilt_factors.size() != tilt_angles.size()) return 1.0;
  const double x = std::clamp(degrees, tilt_angles.front(), tilt_angles.back());
  size_t i = 0;
  double t = 0.0;
  if (!locate(tilt_angles, x, i, t)) return tilt_factors.front();
  const size_t j = std::min(i + 1, tilt_factors.size() - 1);
  return (1.0 - t) * tilt_factors[i] + t * tilt_factors[j];
}

}  // namespace penumbra
