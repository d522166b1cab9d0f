// Options described once (design doc sec. 2): each option's name, kind, range, choices, unit,
// help, and the methods that take it with their default. Every source of a value (the command
// line, a scene file's "settings", the API, Python) goes through the same parse and range check
// here, so a value refused on one is refused on all, with the same words.
#pragma once

#include "penumbra/core/expected.h"

#include <nlohmann/json_fwd.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace penumbra {

enum class OptionKind {
  kFlag,      // present or not (--adaptive)
  kInt,       // a whole number (int64)
  kUnsigned,  // a whole number >= 0 up to 2^64 - 1, written in decimal digits (--seed)
  kReal,      // a finite number
  kRealList,  // finite numbers separated by commas (--boundary 0.05,0.95)
  kChoice,    // one word of `choices`
  kText,      // a name or a path
};

// An option's value once parsed and checked.
using OptionValue = std::variant<bool, int64_t, uint64_t, double, std::vector<double>, std::string>;

// A closed or open interval of numbers.
struct OptionRange {
  double lo = 0.0, hi = 0.0;
  bool open_lo = false, open_hi = false;
  bool contains(double v) const;
  std::string describe() const;  // "[1, 65536]", "(0, 1]"
};

// A method that takes an option: its default as users read it ("64", "" when there is none or
// it is computed, described in the help) and, where it differs from the option's, its range.
struct OptionUse {
  std::string method;
  std::string default_value;
  std::optional<OptionRange> range;
};

struct OptionSpec {
  std::string name;  // the command line's --name; scene settings and Python write it with '_'
  OptionKind kind = OptionKind::kText;
  std::optional<OptionRange> range;  // numbers
  std::vector<std::string> choices;  // kChoice
  int count = 1;                     // kRealList: the number of values
  std::string unit;                  // "m", "s", "texels", ...
  std::string help;
  std::vector<OptionUse> uses;  // empty: every method of the command, no default
  std::string short_name;       // "-o"
  bool repeatable = false;      // may be given more than once (-o a.png -o a.exr)
  bool positional = false;      // the command's SCENE

  // The method's use of this option, or null when `method` does not take it.
  const OptionUse* use(const std::string& method) const;
  bool takenBy(const std::string& method) const { return uses.empty() || use(method); }
  // The range that applies for `method` (its own, else the option's).
  std::optional<OptionRange> rangeFor(const std::string& method) const;
  // The names of the methods that take it, "pathtrace, whitted".
  std::string owners() const;
  // Who takes it and the defaults, grouped: "512" when every one of the command's `methods`
  // takes it with one default, else "pathtrace: 64; whitted, photons: 4" or "whitted, photons";
  // empty when every method takes it without a default.
  std::string usesText(size_t methods) const;
};

// Parses the command line's text for `spec` and checks it for `method` (empty: the option's
// own range). Errors name `where` ("--spp", "settings.pathtrace.spp") and `file` (the scene file,
// or empty for the command line).
Expected<OptionValue> parseOption(const OptionSpec& spec, const std::string& text,
                                  const std::string& method, const std::string& file,
                                  const std::string& where);
// The same for a JSON value (a scene file's settings, Python's keyword arguments as JSON).
Expected<OptionValue> optionFromJson(const OptionSpec& spec, const nlohmann::json& value,
                                     const std::string& method, const std::string& file,
                                     const std::string& where);
// Checks a value of the right kind against the range and choices that apply to `method`.
Status checkOption(const OptionSpec& spec, const OptionValue& value, const std::string& method,
                   const std::string& file, const std::string& where);

// The spec called `name` ("spp" or "--spp") in `specs`, or null.
const OptionSpec* findOption(const std::vector<OptionSpec>& specs, const std::string& name);

}  // namespace penumbra
