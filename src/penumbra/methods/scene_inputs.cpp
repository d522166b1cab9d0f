#include "penumbra/methods/scene_inputs.h"

#include "penumbra/io/daylight_json.h"
#include "penumbra/methods/registry.h"

#include <nlohmann/json.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace penumbra {

namespace {

// A scene this large or this small is probably in another unit than metres (a building in
// millimetres spans tens of kilometres; a room in kilometres, millimetres).
constexpr double kLargestLikely = 5000.0;  // m
constexpr double kSmallestLikely = 0.05;   // m

// The beam of --sky sunny, lx on a plane square to it: a clear day's direct normal illuminance.
constexpr double kSunnyBeam = 60000.0;

bool emits(const Scene& scene) {
  for (const Mesh& m : scene.meshes) {
    for (uint32_t id : m.material_ids) {
      if (id < scene.materials.size() && scene.materials[id].isEmissive() &&
          !scene.materials[id].unlit) {
        return true;
      }
    }
  }
  return false;
}

Expected<DaylightSky> commandSky(const SceneInputOptions& in) {
  nlohmann::json j = {{"ground_reflectance", 0.2},
                      {"horizontal_illuminance", in.sky_illuminance.value_or(10000.0)}};
  if (in.sky == "overcast") {
    j["type"] = 16;
  } else if (in.sky == "uniform") {
    j["type"] = 5;
  } else {
    // The CIE standard clear sky; "sunny" adds the beam, 45 degrees high in the south (the
    // scene's +z, where glTF models face).
    j["type"] = 12;
    j["sun"] = {{"elevation_deg", 45.0}, {"azimuth_deg", 180.0}};
    if (in.sky == "sunny") j["sun_illuminance"] = kSunnyBeam;
  }
  return readSky(j, "", "--sky");
}

}  // namespace

SceneLoadOptions sceneLoadOptions(const SceneInputOptions& in, bool dry_run) {
  SceneLoadOptions o;
  o.files.allow_outside = in.allow_outside_files;
  o.textures.limits.max_size = in.max_texture_size;
  o.textures.decode = !dry_run;
  o.gltf_scene = in.gltf_scene.value_or(-1);
  return o;
}

std::vector<std::string> unitWarnings(const Scene& scene) {
  std::vector<std::string> out;
  glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-lo);
  for (const Mesh& m : scene.meshes) {
    for (const glm::vec3& p : m.positions) {
      lo = glm::min(lo, glm::dvec3(p));
      hi = glm::max(hi, glm::dvec3(p));
    }
  }
  if (!(lo.x <= hi.x)) return out;
  const glm::dvec3 size = hi - lo;
  const double extent = std::max({size.x, size.y, size.z});
  if (extent > kLargestLikely || (extent > 0.0 && extent < kSmallestLikely)) {
    out.push_back(fmt::format(
        "{}: the scene is {:.4g} x {:.4g} x {:.4g} m, {}: if its unit is not the metre, give "
        "--scale (0.001 for millimetres, 0.0254 for inches, 0.01 for centimetres)",
        scene.source, size.x, size.y, size.z,
        extent > kLargestLikely ? "kilometres across" : "a few centimetres small"));
  }
  return out;
}

std::vector<std::string> firstPictureWarnings(const Scene& scene) {
  std::vector<std::string> out;
  if (!hasLightOtherThanSurfaces(scene) && !emits(scene)) {
    out.push_back(fmt::format("{}: {}", scene.source, noLightError(scene, "").message));
  }
  for (std::string& w : unitWarnings(scene)) out.push_back(std::move(w));
  return out;
}

Expected<std::shared_ptr<const Scene>> applySceneInputs(std::shared_ptr<const Scene> scene,
                                                        const SceneInputOptions& in) {
  const bool sky = !in.sky.empty();
  const bool environment = !in.environment.empty();
  if (sky && environment) {
    return inputError("", "--sky", "give --sky or --environment, not both");
  }
  if (!sky && !environment && !in.scale) {
    std::vector<std::string> warnings = unitWarnings(*scene);
    if (warnings.empty()) return scene;
    auto copy = std::make_shared<Scene>(*scene);
    copy->warnings.insert(copy->warnings.end(), warnings.begin(), warnings.end());
    return std::shared_ptr<const Scene>(std::move(copy));
  }
  auto out = std::make_shared<Scene>(*scene);
  if (in.scale) scaleScene(*out, *in.scale);
  if (sky) {
    Expected<DaylightSky> daylight = commandSky(in);
    if (!daylight) return daylight.error();
    out->sky = daylight->sky;
    out->environment = glm::vec3(0.0f);
    if (daylight->sun) out->lights.push_back(*daylight->sun);
  }
  if (environment) {
    out->sky.reset();
    out->environment =
        glm::vec3(float(in.environment[0]), float(in.environment[1]), float(in.environment[2]));
  }
  // Checked again (the scale changes lengths, the sky adds a sun); its warnings (degenerate
  // triangles) were given when the scene was loaded.
  const size_t warned = out->warnings.size();
  PENUMBRA_TRY(validateScene(*out));
  out->warnings.resize(warned);
  for (std::string& w : unitWarnings(*out)) out->warnings.push_back(std::move(w));
  return std::shared_ptr<const Scene>(std::move(out));
}

namespace {

template <typename Options>
Expected<RunContext> prepareRunOf(Options& options, const RunContext& context) {
  Expected<std::vector<std::string>> set =
      applySceneSettings(options, context.scene->settings, context.scene->source, context.given);
  if (!set) return set.error();
  Expected<std::shared_ptr<const Scene>> scene = applySceneInputs(context.scene, options);
  if (!scene) return scene.error();
  RunContext run = context;
  run.scene = *scene;
  options.given = context.given;
  options.given.insert(options.given.end(), set->begin(), set->end());
  return run;
}

}  // namespace

Expected<RunContext> prepareRun(RenderOptions& options, const RunContext& context) {
  return prepareRunOf(options, context);
}

Expected<RunContext> prepareRun(BakeOptions& options, const RunContext& context) {
  return prepareRunOf(options, context);
}

}  // namespace penumbra
