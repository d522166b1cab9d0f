// Values, not syntax: the value targets keep a valid document and let the fuzzer choose which of
// its values to replace and with what. Each pair of input bytes picks a value of the template (a
// number, or an array or object holding numbers) and a hostile replacement: 0, -1, 1e39, 1e300,
// infinity (1e999 in the text), a denormal, 2^53 + 1, a string, an empty array, an empty object,
// null, true, a longer or shorter array, or a double taken from the next eight bytes.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::fuzz {

// The JSON pointers of every value worth replacing: numbers, and arrays and objects (so that a
// whole colour or matrix can be swapped for a string).
inline void collectValues(const nlohmann::json& j, const nlohmann::json::json_pointer& at,
                          std::vector<nlohmann::json::json_pointer>& out) {
  if (j.is_number() || j.is_array() || j.is_object()) {
    if (!at.empty()) out.push_back(at);
  }
  if (j.is_array()) {
    for (size_t i = 0; i < j.size(); ++i) collectValues(j[i], at / i, out);
  } else if (j.is_object()) {
    for (const auto& [key, value] : j.items()) collectValues(value, at / key, out);
  }
}

// The template with the replacements `bytes` ask for, as JSON text.
inline std::string mutateValues(const nlohmann::json& base, std::string_view bytes) {
  nlohmann::json doc = base;
  std::vector<nlohmann::json::json_pointer> values;
  collectValues(doc, nlohmann::json::json_pointer(), values);
  constexpr const char* kInfinity = "\x01inf\x01";
  constexpr const char* kMinusInfinity = "\x01-inf\x01";
  for (size_t at = 0; at + 2 <= bytes.size() && !values.empty(); at += 2) {
    const auto& where = values[uint8_t(bytes[at]) % values.size()];
    if (!doc.contains(where)) continue;  // under a value replaced earlier
    nlohmann::json& v = doc[where];
    switch (uint8_t(bytes[at + 1]) % 16) {
      case 0:
        v = 0;
        break;
      case 1:
        v = -1;
        break;
      case 2:
        v = 1e39;
        break;
      case 3:
        v = 1e300;
        break;
      case 4:
        v = kInfinity;
        break;
      case 5:
        v = kMinusInfinity;
        break;
      case 6:
        v = 1e-320;
        break;
      case 7:
        v = 9007199254740993.0;
        break;
      case 8:
        v = "text";
        break;
      case 9:
        v = nlohmann::json::array();
        break;
      case 10:
        v = nlohmann::json::object();
        break;
      case 11:
        v = nullptr;
        break;
      case 12:
        v = true;
        break;
      case 13:
        if (v.is_array()) v.push_back(v.empty() ? nlohmann::json(1) : v.back());
        break;
      case 14:
        if (v.is_array() && !v.empty()) v.erase(v.size() - 1);
        break;
      case 15: {
        double d = 0.0;
        if (at + 10 <= bytes.size()) {
          std::memcpy(&d, bytes.data() + at + 2, 8);
          at += 8;
        }
        if (d != d) d = 0.0;  // JSON has no NaN; infinity comes as 1e999 above
        v = d;
        break;
      }
    }
  }
  std::string text = doc.dump();
  for (const auto& [token, literal] : {std::pair{kInfinity, "1e999"}, {kMinusInfinity, "-1e999"}}) {
    const std::string quoted = nlohmann::json(token).dump();
    for (size_t p = text.find(quoted); p != std::string::npos; p = text.find(quoted, p)) {
      text.replace(p, quoted.size(), literal);
    }
  }
  return text;
}

}  // namespace penumbra::fuzz
