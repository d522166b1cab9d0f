#include "viewer/script.h"

#include "penumbra/core/file_util.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>

namespace penumbra::viewer {

namespace {

// Key k and the share of the way to key k + 1 at frame `frame` of `frames`.
template <typename T, typename Mix>
T along(const std::vector<T>& keys, int frame, int frames, Mix mix) {
  if (keys.size() == 1 || frames <= 1) return keys.back();
  const double t =
      std::clamp(double(frame) / double(frames - 1), 0.0, 1.0) * double(keys.size() - 1);
  const size_t k = std::min(size_t(t), keys.size() - 2);
  return mix(keys[k], keys[k + 1], float(t - double(k)));
}

Expected<glm::vec3> vec3At(const std::string& path, const std::string& where,
                           const nlohmann::json& j) {
  if (!j.is_array() || j.size() != 3) {
    return inputError(path, where, "must be an array of 3 numbers");
  }
  glm::vec3 v;
  for (int c = 0; c < 3; ++c) {
    if (!j[size_t(c)].is_number() || !std::isfinite(j[size_t(c)].get<double>())) {
      return inputError(path, where, "must be an array of 3 finite numbers");
    }
    v[c] = j[size_t(c)].get<float>();
  }
  return v;
}

}  // namespace

std::optional<glm::vec3> Script::lightAt(int frame, int frames) const {
  if (light_path.empty()) return std::nullopt;
  return along(light_path, frame, frames,
               [](const glm::vec3& a, const glm::vec3& b, float t) { return a + (b - a) * t; });
}

std::optional<CameraKey> Script::cameraAt(int frame, int frames) const {
  if (camera_path.empty()) return std::nullopt;
  return along(camera_path, frame, frames, [](const CameraKey& a, const CameraKey& b, float t) {
    return CameraKey{a.position + (b.position - a.position) * t,
                     a.look_at + (b.look_at - a.look_at) * t};
  });
}

Expected<Script> readScript(const std::string& path) {
  Expected<std::string> text = readFile(path);
  if (!text) return text.error();
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(*text);
  } catch (const nlohmann::json::parse_error& e) {
    return inputError(path, fmt::format("byte {}", e.byte), "not JSON");
  }
  if (!j.is_object()) return inputError(path, "", "must be a JSON object");
  Script s;
  for (const auto& [key, value] : j.items()) {
    if (key == "light") {
      if (!value.is_number_integer() || value.get<int64_t>() < 0 ||
          value.get<int64_t>() > 1 << 20) {
        return inputError(path, "light", "must be a light's index (0, 1, ...)");
      }
      s.light = value.get<int>();
    } else if (key == "light_path") {
      if (!value.is_array() || value.empty()) {
        return inputError(path, "light_path", "must be a non-empty array of positions");
      }
      for (size_t k = 0; k < value.size(); ++k) {
        Expected<glm::vec3> p = vec3At(path, fmt::format("light_path[{}]", k), value[k]);
        if (!p) return p.error();
        s.light_path.push_back(*p);
      }
    } else if (key == "camera_path") {
      if (!value.is_array() || value.empty()) {
        return inputError(path, "camera_path", "must be a non-empty array of cameras");
      }
      for (size_t k = 0; k < value.size(); ++k) {
        const std::string where = fmt::format("camera_path[{}]", k);
        if (!value[k].is_object() || !value[k].contains("position") ||
            !value[k].contains("look_at")) {
          return inputError(path, where, "must be an object with \"position\" and \"look_at\"");
        }
        Expected<glm::vec3> p = vec3At(path, where + ".position", value[k]["position"]);
        if (!p) return p.error();
        Expected<glm::vec3> l = vec3At(path, where + ".look_at", value[k]["look_at"]);
        if (!l) return l.error();
        if (*p == *l) return inputError(path, where, "position and look_at are the same point");
        s.camera_path.push_back({*p, *l});
      }
    } else if (key == "drop") {
      if (!value.is_object() || !value.contains("frame") || !value.contains("file") ||
          !value["frame"].is_number_integer() || !value["file"].is_string() ||
          value["frame"].get<int64_t>() < 0 || value["frame"].get<int64_t>() > 1 << 20) {
        return inputError(path, "drop", "must be {\"frame\": N, \"file\": \"path\"}");
      }
      s.drop_frame = value["frame"].get<int>();
      s.drop_file = value["file"].get<std::string>();
    } else {
      return inputError(path, key, "unknown key (light, light_path, camera_path, drop)");
    }
  }
  return s;
}

}  // namespace penumbra::viewer
