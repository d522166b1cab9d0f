#include "penumbra/io/subsurface_json.h"

#include "penumbra/scene/heterogeneous_media.h"
#include "penumbra/scene/media.h"

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <memory>

namespace penumbra {

namespace {

std::string presetList() {
  std::string names;
  for (const char* n : subsurfacePresetNames())
    names += (names.empty() ? "" : ", ") + std::string(n);
  return names;
}

Expected<glm::dvec3> colour(const nlohmann::json& j, const std::string& file,
                            const std::string& place) {
  if (j.is_number()) {
    const double v = j.get<double>();
    if (!std::isfinite(v)) return inputError(file, place, "must be a finite number");
    return glm::dvec3(v);
  }
  if (!j.is_array() || j.size() != 3) {
    return inputError(file, place, "must be a number or an array of 3 numbers");
  }
  glm::dvec3 v(0.0);
  for (int i = 0; i < 3; ++i) {
    const nlohmann::json& x = j[size_t(i)];
    if (!x.is_number() || !std::isfinite(x.get<double>())) {
      return inputError(file, fmt::format("{}[{}]", place, i), "must be a finite number");
    }
    v[i] = x.get<double>();
  }
  return v;
}

}  // namespace

Expected<Subsurface> parseSubsurface(const nlohmann::json& block, const std::string& file,
                                     const std::string& place) {
  auto fromPreset = [&](const std::string& name, const std::string& where) -> Expected<Subsurface> {
    std::optional<Subsurface> s = subsurfacePreset(name);
    if (!s) {
      return inputError(
          file, where,
          fmt::format("unknown measured material '{}' (known: {})", name, presetList()));
    }
    return *s;
  };
  if (block.is_string()) return fromPreset(block.get<std::string>(), place);
  if (!block.is_object()) {
    return inputError(file, place, "must be a preset name or an object");
  }
  for (auto it = block.begin(); it != block.end(); ++it) {
    const std::string& k = it.key();
    if (k != "preset" && k != "sigma_s_prime" && k != "sigma_a" && k != "eta" && k != "g" &&
        k != "scale" && k != "albedo" && k != "distance_mm" && k != "pattern" && k != "grid") {
      return inputError(file, place + "." + k,
                        "unknown key (known keys: preset, sigma_s_prime, sigma_a, albedo, "
                        "distance_mm, eta, g, scale, pattern, grid)");
    }
  }
  const bool preset = block.contains("preset");
  const bool coefficients = block.contains("sigma_s_prime") || block.contains("sigma_a");
  const bool albedo = block.contains("albedo") || block.contains("distance_mm");
  if (int(preset) + int(coefficients) + int(albedo) != 1) {
    return inputError(
        file, place,
        "give exactly one of: preset; sigma_s_prime and sigma_a; albedo and distance_mm");
  }
  double eta = 1.3;
  if (block.contains("eta")) {
    const nlohmann::json& e = block.at("eta");
    if (!e.is_number() || !std::isfinite(e.get<double>())) {
      return inputError(file, place + ".eta", "must be a finite number");
    }
    eta = e.get<double>();
  }
  double g = 0.0;
  if (block.contains("g")) {
    const nlohmann::json& e = block.at("g");
    if (!e.is_number() || !(e.get<double>() > -1.0 && e.get<double>() < 1.0)) {
      return inputError(file, place + ".g", "must be a number in (-1, 1)");
    }
    g = e.get<double>();
  }
  double scale = 1.0;
  if (block.contains("scale")) {
    const nlohmann::json& e = block.at("scale");
    if (!e.is_number() || !(e.get<double>() > 0.0) || !std::isfinite(e.get<double>())) {
      return inputError(file, place + ".scale", "must be a positive number");
    }
    scale = e.get<double>();
  }
  Expected<Subsurface> medium = Subsurface{};
  if (preset) {
    if (!block.at("preset").is_string()) {
      return inputError(file, place + ".preset", "must be a string");
    }
    medium = fromPreset(block.at("preset").get<std::string>(), place + ".preset");
    if (medium && block.contains("eta")) medium->eta = eta;
  } else if (coefficients) {
    for (const char* k : {"sigma_s_prime", "sigma_a"}) {
      if (!block.contains(k)) return inputError(file, place, fmt::format("needs {} too", k));
    }
    Expected<glm::dvec3> s = colour(block.at("sigma_s_prime"), file, place + ".sigma_s_prime");
    if (!s) return s.error();
    Expected<glm::dvec3> a = colour(block.at("sigma_a"), file, place + ".sigma_a");
    if (!a) return a.error();
    medium = subsurfaceFromCoefficients(*s, *a, eta);
  } else {
    for (const char* k : {"albedo", "distance_mm"}) {
      if (!block.contains(k)) return inputError(file, place, fmt::format("needs {} too", k));
    }
    Expected<glm::dvec3> al = colour(block.at("albedo"), file, place + ".albedo");
    if (!al) return al.error();
    Expected<glm::dvec3> d = colour(block.at("distance_mm"), file, place + ".distance_mm");
    if (!d) return d.error();
    medium = subsurfaceFromAlbedo(*al, *d * 1e-3, eta);
  }
  if (!medium) {
    // The medium's own checks name the value; the place is the block.
    const Error& e = medium.error();
    return e.file.empty() ? inputError(file, place, e.message) : e;
  }
  medium->g = g;
  medium->sigma_s_prime *= scale;
  medium->sigma_a *= scale;
  if (Status s = checkSubsurface(*medium); !s.ok())
    return inputError(file, place, s.error().message);
  // Heterogeneity (scene/heterogeneous_media.h): a pattern over these coefficients, or a grid
  // file (relative to the scene file).
  if (block.contains("pattern") && block.contains("grid")) {
    return inputError(file, place, "give pattern or grid, not both");
  }
  if (block.contains("pattern")) {
    const nlohmann::json& p = block.at("pattern");
    if (!p.is_string() || !isMediumPattern(p.get<std::string>())) {
      return inputError(file, place + ".pattern",
                        fmt::format("must be one of: {}", mediumPatternNames()));
    }
    medium->pattern = p.get<std::string>();
  }
  if (block.contains("grid")) {
    const nlohmann::json& p = block.at("grid");
    if (!p.is_string() || p.get<std::string>().empty()) {
      return inputError(file, place + ".grid", "must be the path of a medium grid file");
    }
    std::filesystem::path path(p.get<std::string>());
    if (path.is_relative()) path = std::filesystem::path(file).parent_path() / path;
    Expected<MediumGrid> grid = readMediumGrid(path.string());
    if (!grid) return grid.error();
    medium->grid = std::make_shared<const MediumGrid>(std::move(*grid));
  }
  return *medium;
}

}  // namespace penumbra
