// Checked readers for values of the JSON files users write (calculation objects, daylight): the
// scene format's rules, each error naming the file and the key path ("calculation[2].normal"):
// a wrong type, a non-finite number, a number outside its range or an unknown key.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/io/json_guard.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <initializer_list>
#include <string>

namespace penumbra {

// "place.key", or "key" at the top level.
inline std::string keyOf(const std::string& place, const std::string& key) {
  return place.empty() ? key : place + "." + key;
}

struct JsonReader {
  const std::string& file;  // named in every error

  using json = nlohmann::json;

  Error error(const std::string& place, const std::string& message) const {
    return inputError(file, place, message);
  }
  Status keys(const json& obj, const std::string& place,
              std::initializer_list<const char*> allowed) const {
    for (auto it = obj.begin(); it != obj.end(); ++it) {
      bool known = false;
      for (const char* a : allowed) known = known || it.key() == a;
      if (known) continue;
      std::string list;
      for (const char* a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
      return error(keyOf(place, it.key()), fmt::format("unknown key (known keys: {})", list));
    }
    return {};
  }
  Expected<double> number(const json& j, const std::string& place) const {
    if (!j.is_number()) {
      return error(place, fmt::format("must be a number, not {}", jsonTypeName(j)));
    }
    const double v = j.get<double>();
    if (!std::isfinite(v)) return error(place, "must be a finite number");
    return v;
  }
  Expected<double> length(const json& obj, const std::string& place, const char* key,
                          double fallback, bool positive) const {
    if (!obj.contains(key)) return fallback;
    Expected<double> v = number(obj.at(key), keyOf(place, key));
    if (!v) return v.error();
    if (positive ? !(*v > 0.0) : !(*v >= 0.0)) {
      return error(keyOf(place, key), fmt::format("{} must be {} length in metres", *v,
                                                  positive ? "a positive" : "a non-negative"));
    }
    if (*v > 1e6) return error(keyOf(place, key), fmt::format("{} m is over 1,000 km", *v));
    return v;
  }
  Expected<glm::dvec3> vec3(const json& j, const std::string& place) const {
    if (!j.is_array() || j.size() != 3) {
      return error(place, fmt::format("must be an array of 3 numbers, not {}",
                                      j.is_array() ? fmt::format("{}", j.size())
                                                   : std::string(jsonTypeName(j))));
    }
    glm::dvec3 v(0.0);
    for (int i = 0; i < 3; ++i) {
      Expected<double> x = number(j[size_t(i)], fmt::format("{}[{}]", place, i));
      if (!x) return x.error();
      if (std::fabs(*x) > 1e9) {
        return error(fmt::format("{}[{}]", place, i), fmt::format("{} is over 1e9 m", *x));
      }
      v[i] = *x;
    }
    return v;
  }
  Expected<glm::dvec3> direction(const json& j, const std::string& place) const {
    Expected<glm::dvec3> v = vec3(j, place);
    if (!v) return v;
    const double len = glm::length(*v);
    if (!(len > 1e-12)) return error(place, "must be a direction, not a zero vector");
    return *v / len;
  }
  Expected<std::string> string(const json& j, const std::string& place) const {
    if (!j.is_string()) {
      return error(place, fmt::format("must be a string, not {}", jsonTypeName(j)));
    }
    return j.get<std::string>();
  }
  // obj[key] as a number in [lo, hi], or `fallback` when absent.
  Expected<double> numberIn(const json& obj, const std::string& place, const char* key,
                            double fallback, double lo, double hi) const {
    if (!obj.contains(key)) return fallback;
    Expected<double> v = number(obj.at(key), keyOf(place, key));
    if (!v) return v.error();
    if (!(*v >= lo && *v <= hi)) {
      return error(keyOf(place, key), fmt::format("{} is outside [{}, {}]", *v, lo, hi));
    }
    return v;
  }
};

}  // namespace penumbra
