#include "penumbra/methods/option_spec.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>

namespace penumbra {

bool OptionRange::contains(double v) const {
  const bool above_lo = open_lo ? v > lo : v >= lo;
  const bool below_hi = open_hi ? v < hi : v <= hi;
  return above_lo && below_hi;
}

namespace {

// 65536 and 1048576 as they are, 2^28 and 2^32 as powers of two, 1e9 and 1e30 as such.
std::string formatBound(double v) {
  const double a = std::fabs(v);
  if (a >= double(1 << 24) && a == std::floor(a) && std::exp2(std::round(std::log2(a))) == a) {
    return fmt::format("{}2^{}", v < 0 ? "-" : "", int(std::round(std::log2(a))));
  }
  if (a < 1e7 && v == std::floor(v)) return fmt::format("{}", int64_t(v));
  std::string s = fmt::format("{:g}", v);
  if (const size_t e = s.find("e+"); e != std::string::npos) s.erase(e + 1, 1);
  return s;
}

}  // namespace

std::string OptionRange::describe() const {
  return fmt::format("{}{}, {}{}", open_lo ? '(' : '[', formatBound(lo), formatBound(hi),
                     open_hi ? ')' : ']');
}

const OptionUse* OptionSpec::use(const std::string& method) const {
  for (const OptionUse& u : uses) {
    if (u.method == method) return &u;
  }
  return nullptr;
}

std::optional<OptionRange> OptionSpec::rangeFor(const std::string& method) const {
  if (const OptionUse* u = use(method); u && u->range) return u->range;
  return range;
}

std::string OptionSpec::owners() const {
  std::vector<std::string> names;
  for (const OptionUse& u : uses) names.push_back(u.method);
  return fmt::format("{}", fmt::join(names, ", "));
}

std::string OptionSpec::usesText(size_t methods) const {
  std::vector<std::pair<std::string, std::vector<std::string>>> groups;  // default, methods
  for (const OptionUse& u : uses) {
    auto it = std::find_if(groups.begin(), groups.end(),
                           [&](const auto& g) { return g.first == u.default_value; });
    if (it == groups.end()) {
      groups.push_back({u.default_value, {u.method}});
    } else {
      it->second.push_back(u.method);
    }
  }
  if (groups.size() == 1 && uses.size() == methods) return groups[0].first;
  std::vector<std::string> parts;
  for (const auto& [value, names] : groups) {
    parts.push_back(value.empty() ? fmt::format("{}", fmt::join(names, ", "))
                                  : fmt::format("{}: {}", fmt::join(names, ", "), value));
  }
  return fmt::format("{}", fmt::join(parts, "; "));
}

const OptionSpec* findOption(const std::vector<OptionSpec>& specs, const std::string& name) {
  std::string key = name;
  while (!key.empty() && key[0] == '-') key.erase(0, 1);
  std::replace(key.begin(), key.end(), '_', '-');
  for (const OptionSpec& s : specs) {
    if (s.name == key) return &s;
  }
  return nullptr;
}

namespace {

Error bad(const std::string& file, const std::string& where, std::string message) {
  return inputError(file, where, std::move(message));
}

// A whole number in decimal digits with an optional sign.
std::optional<int64_t> parseInteger(const std::string& text) {
  int64_t v = 0;
  const char* begin = text.data() + (text.starts_with('+') ? 1 : 0);
  const auto [end, ec] = std::from_chars(begin, text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size()) return std::nullopt;
  return v;
}

// A number as strtod reads it, the whole text.
std::optional<double> parseReal(const std::string& text) {
  if (text.empty() || std::isspace(static_cast<unsigned char>(text[0]))) return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size()) return std::nullopt;
  return v;
}

Status checkNumber(const OptionSpec& spec, double v, const std::string& shown,
                   const std::string& method, const std::string& file, const std::string& where) {
  if (!std::isfinite(v)) return bad(file, where, fmt::format("'{}' is not a finite number", shown));
  const std::optional<OptionRange> range = spec.rangeFor(method);
  if (range && !range->contains(v)) {
    return bad(file, where, fmt::format("{} is out of range {}", shown, range->describe()));
  }
  return {};
}

std::string shownValue(const OptionValue& value) {
  return std::visit(
      [](const auto& v) -> std::string {
        using T = std::decay_t<decltype(v)>;
        if constexpr (std::is_same_v<T, std::vector<double>>) {
          return fmt::format("{}", fmt::join(v, ","));
        } else if constexpr (std::is_same_v<T, bool>) {
          return v ? "true" : "false";
        } else {
          return fmt::format("{}", v);
        }
      },
      value);
}

Expected<OptionValue> parseText(const OptionSpec& spec, const std::string& text,
                                const std::string& file, const std::string& where) {
  switch (spec.kind) {
    case OptionKind::kFlag:
      if (text == "true" || text == "1") return OptionValue(true);
      if (text == "false" || text == "0") return OptionValue(false);
      return bad(file, where, fmt::format("'{}' is not true or false", text));
    case OptionKind::kInt: {
      const std::optional<int64_t> v = parseInteger(text);
      if (!v) return bad(file, where, fmt::format("'{}' is not an integer", text));
      return OptionValue(*v);
    }
    case OptionKind::kUnsigned: {
      if (text.find_first_not_of("0123456789") != std::string::npos) {
        return bad(file, where, fmt::format("'{}' is not a non-negative integer", text));
      }
      uint64_t v = 0;
      const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
      if (ec != std::errc() || end != text.data() + text.size()) {
        return bad(file, where, fmt::format("{} is larger than 2^64 - 1", text));
      }
      return OptionValue(v);
    }
    case OptionKind::kReal: {
      const std::optional<double> v = parseReal(text);
      if (!v) return bad(file, where, fmt::format("'{}' is not a number", text));
      return OptionValue(*v);
    }
    case OptionKind::kRealList: {
      std::vector<double> values;
      size_t start = 0;
      while (start <= text.size()) {
        const size_t comma = std::min(text.find(',', start), text.size());
        const std::string part = text.substr(start, comma - start);
        const std::optional<double> v = parseReal(part);
        if (!v) return bad(file, where, fmt::format("'{}' is not a number", part));
        values.push_back(*v);
        start = comma + 1;
      }
      return OptionValue(std::move(values));
    }
    case OptionKind::kChoice:
    case OptionKind::kText:
      return OptionValue(text);
  }
  return bad(file, where, "unknown option kind");
}

}  // namespace

Status checkOption(const OptionSpec& spec, const OptionValue& value, const std::string& method,
                   const std::string& file, const std::string& where) {
  const std::string shown = shownValue(value);
  switch (spec.kind) {
    case OptionKind::kInt:
      return checkNumber(spec, double(std::get<int64_t>(value)), shown, method, file, where);
    case OptionKind::kUnsigned:
      return checkNumber(spec, double(std::get<uint64_t>(value)), shown, method, file, where);
    case OptionKind::kReal:
      return checkNumber(spec, std::get<double>(value), shown, method, file, where);
    case OptionKind::kRealList: {
      const auto& values = std::get<std::vector<double>>(value);
      if (int(values.size()) != spec.count) {
        return bad(file, where,
                   fmt::format("'{}' is not {} numbers separated by commas", shown, spec.count));
      }
      for (double v : values) {
        PENUMBRA_TRY(checkNumber(spec, v, fmt::format("{}", v), method, file, where));
      }
      return {};
    }
    case OptionKind::kChoice: {
      const std::string& v = std::get<std::string>(value);
      if (std::find(spec.choices.begin(), spec.choices.end(), v) == spec.choices.end()) {
        if (spec.name == "method") {
          return bad(file, "",
                     fmt::format("unknown --method '{}' (available: {})", v,
                                 fmt::join(spec.choices, ", ")));
        }
        return bad(file, where,
                   fmt::format("'{}' is not one of {}", v, fmt::join(spec.choices, ", ")));
      }
      return {};
    }
    case OptionKind::kText:
      if (std::get<std::string>(value).empty()) {
        return bad(file, where, "an empty value is not allowed");
      }
      return {};
    case OptionKind::kFlag:
      return {};
  }
  return {};
}

Expected<OptionValue> parseOption(const OptionSpec& spec, const std::string& text,
                                  const std::string& method, const std::string& file,
                                  const std::string& where) {
  if (text.empty()) return bad(file, where, "an empty value is not allowed");
  Expected<OptionValue> value = parseText(spec, text, file, where);
  if (!value) return value;
  // The message shows the value as it was written.
  if (spec.kind == OptionKind::kInt || spec.kind == OptionKind::kReal ||
      spec.kind == OptionKind::kUnsigned) {
    const double v = spec.kind == OptionKind::kInt        ? double(std::get<int64_t>(*value))
                     : spec.kind == OptionKind::kUnsigned ? double(std::get<uint64_t>(*value))
                                                          : std::get<double>(*value);
    PENUMBRA_TRY(checkNumber(spec, v, text, method, file, where));
    return value;
  }
  PENUMBRA_TRY(checkOption(spec, *value, method, file, where));
  return value;
}

Expected<OptionValue> optionFromJson(const OptionSpec& spec, const nlohmann::json& value,
                                     const std::string& method, const std::string& file,
                                     const std::string& where) {
  const auto wrong = [&](const char* what) {
    return bad(file, where, fmt::format("must be {}, not {}", what, value.dump()));
  };
  OptionValue v;
  switch (spec.kind) {
    case OptionKind::kFlag:
      if (!value.is_boolean()) return wrong("true or false");
      v = value.get<bool>();
      break;
    case OptionKind::kInt:
      if (!value.is_number_integer()) return wrong("an integer");
      if (value.is_number_unsigned() && value.get<uint64_t>() > uint64_t(INT64_MAX)) {
        return bad(file, where, fmt::format("{} is out of range", value.dump()));
      }
      v = value.get<int64_t>();
      break;
    case OptionKind::kUnsigned:
      // A whole number >= 0, however the JSON holds it (parsed files hold it unsigned, values
      // built in code signed).
      if (!value.is_number_integer() || (!value.is_number_unsigned() && value.get<int64_t>() < 0)) {
        return wrong("a non-negative integer");
      }
      v = value.get<uint64_t>();
      break;
    case OptionKind::kReal:
      if (!value.is_number()) return wrong("a number");
      v = value.get<double>();
      break;
    case OptionKind::kRealList: {
      if (!value.is_array()) return wrong("an array of numbers");
      std::vector<double> values;
      for (const nlohmann::json& x : value) {
        if (!x.is_number()) return wrong("an array of numbers");
        values.push_back(x.get<double>());
      }
      v = std::move(values);
      break;
    }
    case OptionKind::kChoice:
    case OptionKind::kText:
      if (!value.is_string()) return wrong("a string");
      v = value.get<std::string>();
      break;
  }
  // Integers show as the file has them (2^40 stays 1099511627776, not 1.09951e+12).
  if (spec.kind == OptionKind::kInt || spec.kind == OptionKind::kUnsigned) {
    const double d = value.get<double>();
    PENUMBRA_TRY(checkNumber(spec, d, value.dump(), method, file, where));
    return v;
  }
  PENUMBRA_TRY(checkOption(spec, v, method, file, where));
  return v;
}

}  // namespace penumbra
