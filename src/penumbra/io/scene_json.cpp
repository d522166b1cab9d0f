// Penumbra's JSON scene format (docs/scene-format.md) and the loaders' front door.
//
// The reader is strict: an unknown key, a value of the wrong type or an array of the wrong
// length is an error naming its key path ("meshes[2].transform.scale"), so that a typo never
// silently changes a scene. Mesh files are loaded by their own loaders (which name the mesh file
// in their errors), transformed to world space and merged.
#include "penumbra/core/file_util.h"
#include "penumbra/core/memory.h"
#include "penumbra/geometry/icosphere.h"
#include "penumbra/io/calculation_objects.h"
#include "penumbra/io/daylight_json.h"
#include "penumbra/io/image_io.h"
#include "penumbra/io/json_guard.h"
#include "penumbra/io/luminaire_io.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/io/subsurface_json.h"
#include "penumbra/io/texture_loader.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/builtin.h"
#include "penumbra/scene/coplanar_emitters.h"
#include "penumbra/scene/media.h"

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/matrix.hpp>
#include <glm/trigonometric.hpp>

#include <fmt/format.h>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <map>
#include <numbers>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

namespace penumbra {

namespace {

using nlohmann::json;

std::string keyPath(const std::string& parent, const std::string& key) {
  return parent.empty() ? key : parent + "." + key;
}

// The world_from_object transform of a mesh file, and what it does to vectors.
struct Placement {
  glm::dmat4 world_from_object{1.0};

  glm::vec3 point(const glm::vec3& p) const {
    return glm::vec3(world_from_object * glm::dvec4(glm::dvec3(p), 1.0));
  }
  glm::vec3 direction(const glm::vec3& d) const {
    const glm::dvec3 v = glm::dmat3(world_from_object) * glm::dvec3(d);
    const double len = glm::length(v);
    return len > 0.0 ? glm::vec3(v / len) : glm::vec3(d);
  }
};

// A "meshes" entry: a mesh file (`resolved`) or a sphere of subdivision level `sphere_level`,
// with the material that replaces the file's, its placement and its name.
struct MeshEntry {
  std::string resolved;
  int sphere_level = -1;  // -1: a mesh file
  std::optional<uint32_t> material;
  Placement placement;
  std::string name;
};

class SceneJsonReader {
 public:
  SceneJsonReader(const std::string& path, std::function<void(Scene&)> complete,
                  const SceneLoadOptions& options)
      : path_(path),
        complete_(std::move(complete)),
        options_(options),
        textures_(options.textures) {}

  Expected<Scene> read(const json& root);

 private:
  Error error(const std::string& place, std::string message) const {
    return inputError(path_, place, std::move(message));
  }

  // Every key of `obj` must be in `allowed`; keys in `reserved` are named as not supported yet.
  Status checkKeys(const json& obj, const std::string& place,
                   std::initializer_list<const char*> allowed,
                   std::initializer_list<std::pair<const char*, const char*>> reserved = {}) const;
  Expected<const json*> object(const json& parent, const char* key, const std::string& place,
                               bool required) const;
  Expected<double> number(const json& j, const std::string& place) const;
  Expected<glm::dvec3> vec3(const json& j, const std::string& place) const;
  Expected<std::string> string(const json& j, const std::string& place) const;
  // `file` resolved against the scene file's directory; an error at `place` when it is not a
  // regular file.
  Expected<std::string> existingFile(const std::string& file, const std::string& place) const;
  // A 3-vector that is a non-negative colour (reflectance in [0, 1] when `at_most_one`).
  Expected<glm::vec3> colour(const json& j, const std::string& place, bool at_most_one) const;
  Expected<glm::vec3> unitDirection(const json& j, const std::string& place) const;
  // A radiance: one non-negative number (grey) or a non-negative colour.
  Expected<glm::vec3> environment(const json& j, const std::string& place) const;

  Status readMaterials(const json& root, Scene& scene);
  // Every image the materials name, planned before any is decoded (io/texture_loader.h).
  Status planTextures(const json& root);
  Status readMaterial(const json& entry, const std::string& place, const std::string& name,
                      bool named, Scene& scene);
  // A texture slot: a file name, or {"file", "uv_set", "wrap", "filter", "offset", "scale",
  // "rotation"} (docs/scene-format.md). `colour`: an sRGB colour image.
  Expected<TextureBinding> readTexture(const json& entry, const std::string& place, bool colour);
  // "alpha", "alpha_mode", "alpha_cutoff" and "coverage_texture".
  Status readCoverage(const json& entry, const std::string& place, Material& m);
  // "type" (diffuse, mirror, glass), "specular" and "ior" (Material::scattering).
  Status readScattering(const json& entry, const std::string& place, Material& m);
  Status readMesh(const json& entry, const std::string& place, Scene& scene);
  // The spheres of all entries counted before any is made: a few lines of JSON can ask for
  // hundreds of millions of triangles. Refused when the scene would not fit in memory.
  Status planSpheres(const json& meshes) const;
  // "file" (an existing .obj, .gltf, .glb or .ply) or "sphere" (a subdivision level).
  Status readMeshSource(const json& entry, const std::string& place, MeshEntry& m) const;
  // "material", "transform" and "name".
  Status readMeshOptions(const json& entry, const std::string& place, MeshEntry& m) const;
  Expected<Placement> readTransform(const json& t, const std::string& place) const;
  Status readLight(const json& entry, const std::string& place, Scene& scene);
  Status readLuminaire(const json& entry, const std::string& place, Scene& scene);
  // A luminaire file's photometry and its LDT.
  using LuminaireData = std::pair<Photometry, std::shared_ptr<const LuminaireDistribution>>;
  // An array: count [nx, nz] luminaires spacing [dx, dz] apart along world x and z, centred on
  // the position.
  struct LuminaireArray {
    int nx = 1, nz = 1;
    double dx = 0.0, dz = 0.0;
  };
  // entry[key] as a number, or `fallback` when the entry has no `key`.
  Expected<double> optionalNumber(const json& entry, const std::string& place, const char* key,
                                  double fallback) const;
  // The photometry and LDT of `file` at the entry's tilt_deg, read once per file and tilt.
  Expected<const LuminaireData*> luminaireData(const json& entry, const std::string& place,
                                               const std::string& file);
  // The nadir ("aim") and C0 ("rotation_deg").
  Status readLuminaireAim(const json& entry, const std::string& place, LuminaireLight& l) const;
  // Scale: I_max / 683 W/sr per LDT unit (Wallner eq. 12), times what the user changes: the
  // factor of "dimming", "lamps" and "flux_lm".
  Expected<double> luminaireFactor(const json& entry, const std::string& place,
                                   const std::string& file, const Photometry& photometry,
                                   const LuminaireDistribution& distribution) const;
  Status readLuminaireArray(const json& a, const std::string& place, LuminaireArray& array) const;
  Status readCamera(const json& cam, const std::string& place, Scene& scene) const;

  const std::string& path_;
  // Adds what the caller has in memory (parseSceneJson) before the scene is validated.
  std::function<void(Scene&)> complete_;
  const SceneLoadOptions& options_;
  TextureCache textures_;
  std::map<std::string, uint32_t> material_index_;
  // The luminaire files read so far (resolved path, tilt): their photometry and LDT.
  std::map<std::pair<std::string, double>, LuminaireData> luminaires_;
};

Status SceneJsonReader::checkKeys(
    const json& obj, const std::string& place, std::initializer_list<const char*> allowed,
    std::initializer_list<std::pair<const char*, const char*>> reserved) const {
  for (auto it = obj.begin(); it != obj.end(); ++it) {
    const std::string& key = it.key();
    bool known = false;
    for (const char* a : allowed) known = known || key == a;
    if (known) continue;
    for (const auto& [name, what] : reserved) {
      if (key == name)
        return error(keyPath(place, key), fmt::format("{} is not supported yet", what));
    }
    std::string expected;
    for (const char* a : allowed) expected += (expected.empty() ? "" : ", ") + std::string(a);
    return error(keyPath(place, key), fmt::format("unknown key (known keys: {})", expected));
  }
  return {};
}

Expected<const json*> SceneJsonReader::object(const json& parent, const char* key,
                                              const std::string& place, bool required) const {
  auto it = parent.find(key);
  if (it == parent.end()) {
    if (required) return error(keyPath(place, key), "missing");
    return static_cast<const json*>(nullptr);
  }
  if (!it->is_object()) {
    return error(keyPath(place, key), fmt::format("must be an object, not {}", jsonTypeName(*it)));
  }
  return &*it;
}

Expected<double> SceneJsonReader::number(const json& j, const std::string& place) const {
  if (!j.is_number()) return error(place, fmt::format("must be a number, not {}", jsonTypeName(j)));
  const double v = j.get<double>();
  if (!std::isfinite(v)) return error(place, "must be a finite number");
  return v;
}

Expected<glm::dvec3> SceneJsonReader::vec3(const json& j, const std::string& place) const {
  if (!j.is_array()) {
    return error(place, fmt::format("must be an array of 3 numbers, not {}", jsonTypeName(j)));
  }
  if (j.size() != 3) {
    return error(place, fmt::format("must be an array of 3 numbers, not {}", j.size()));
  }
  glm::dvec3 v(0.0);
  for (int i = 0; i < 3; ++i) {
    Expected<double> x = number(j[static_cast<size_t>(i)], fmt::format("{}[{}]", place, i));
    if (!x.ok()) return x.error();
    v[i] = *x;
  }
  return v;
}

Expected<std::string> SceneJsonReader::string(const json& j, const std::string& place) const {
  if (!j.is_string()) return error(place, fmt::format("must be a string, not {}", jsonTypeName(j)));
  return j.get<std::string>();
}

Expected<std::string> SceneJsonReader::existingFile(const std::string& file,
                                                    const std::string& place) const {
  const std::string resolved = resolveRelativeTo(path_, file);
  std::error_code ec;
  if (!std::filesystem::exists(resolved, ec)) {
    return error(place, fmt::format("'{}' does not exist (looked for {})", file, resolved));
  }
  if (Status regular = checkInputFile(resolved); !regular.ok()) {
    return error(place, fmt::format("'{}' {}", file, regular.error().message));
  }
  return resolved;
}

Expected<glm::vec3> SceneJsonReader::colour(const json& j, const std::string& place,
                                            bool at_most_one) const {
  Expected<glm::dvec3> v = vec3(j, place);
  if (!v.ok()) return v.error();
  for (int i = 0; i < 3; ++i) {
    if ((*v)[i] < 0.0 || (at_most_one && (*v)[i] > 1.0)) {
      return error(fmt::format("{}[{}]", place, i),
                   fmt::format("{} is outside {}", (*v)[i], at_most_one ? "[0, 1]" : "[0, inf)"));
    }
  }
  return glm::vec3(*v);
}

Expected<glm::vec3> SceneJsonReader::unitDirection(const json& j, const std::string& place) const {
  Expected<glm::dvec3> v = vec3(j, place);
  if (!v.ok()) return v.error();
  if (!(glm::length(*v) > 0.0)) return error(place, "a direction must not be zero");
  return glm::vec3(glm::normalize(*v));
}

Expected<glm::vec3> SceneJsonReader::environment(const json& j, const std::string& place) const {
  if (j.is_array()) return colour(j, place, false);
  if (!j.is_number()) {
    return error(place,
                 fmt::format("must be a number or an array of 3 numbers, not {}", jsonTypeName(j)));
  }
  Expected<double> v = number(j, place);
  if (!v.ok()) return v.error();
  if (*v < 0.0) return error(place, fmt::format("{} is outside [0, inf)", *v));
  return glm::vec3(float(*v));
}

Status SceneJsonReader::planTextures(const json& root) {
  if (!root.contains("materials")) return {};
  const json& materials = root.at("materials");
  if (!materials.is_object() && !materials.is_array()) return {};  // readMaterials refuses it
  static constexpr std::pair<const char*, TextureKind> kSlots[] = {
      {"reflectance_texture", TextureKind::kColour},
      {"emission_texture", TextureKind::kColour},
      {"coverage_texture", TextureKind::kData},
      {"normal_map", TextureKind::kNormalMap}};
  for (auto it = materials.begin(); it != materials.end(); ++it) {
    if (!it->is_object()) continue;
    const std::string place = materials.is_array()
                                  ? fmt::format("materials[{}]", it - materials.begin())
                                  : "materials." + it.key();
    for (const auto& [key, kind] : kSlots) {
      if (!it->contains(key)) continue;
      const json& slot = it->at(key);
      const json& file = slot.is_object() && slot.contains("file") ? slot.at("file") : slot;
      if (!file.is_string()) continue;  // readMaterial names what is wrong
      const std::string at = fmt::format("{}.{}", place, key);
      Expected<std::string> resolved = existingFile(file.get<std::string>(), at);
      if (!resolved) return resolved.error();
      PENUMBRA_TRY(textures_.planFile(*resolved, kind, path_, at));
    }
  }
  return {};
}

Status SceneJsonReader::readMaterials(const json& root, Scene& scene) {
  if (!root.contains("materials")) return {};
  const json& materials = root.at("materials");
  // An object of materials by name, or an array of them, each with its "name" (the order mesh
  // arrays count them in, penumbra.h: Scene::fromArrays).
  if (materials.is_array()) {
    for (size_t i = 0; i < materials.size(); ++i) {
      const std::string place = fmt::format("materials[{}]", i);
      const json& entry = materials[i];
      std::string name = fmt::format("material {}", i);
      if (entry.is_object() && entry.contains("name")) {
        Expected<std::string> n = string(entry.at("name"), place + ".name");
        if (!n) return n.error();
        name = *n;
      }
      if (material_index_.contains(name)) {
        return error(place + ".name", fmt::format("'{}' names an earlier material too", name));
      }
      PENUMBRA_TRY(readMaterial(entry, place, name, /*named=*/true, scene));
    }
    return {};
  }
  Expected<const json*> object_or_none = object(root, "materials", "", false);
  if (!object_or_none.ok()) {
    return error("materials",
                 fmt::format("must be an object or an array, not {}", jsonTypeName(materials)));
  }
  for (auto it = materials.begin(); it != materials.end(); ++it) {
    PENUMBRA_TRY(readMaterial(*it, "materials." + it.key(), it.key(), /*named=*/false, scene));
  }
  return {};
}

Expected<TextureBinding> SceneJsonReader::readTexture(const json& entry, const std::string& place,
                                                      bool colour) {
  const json* spec = &entry;
  json object;
  if (entry.is_string()) {
    object = json{{"file", entry}};
    spec = &object;
  } else if (!entry.is_object()) {
    return error(place,
                 fmt::format("must be a file name or an object, not {}", jsonTypeName(entry)));
  }
  PENUMBRA_TRY(
      checkKeys(*spec, place, {"file", "uv_set", "wrap", "filter", "offset", "scale", "rotation"}));
  if (!spec->contains("file")) return error(place + ".file", "missing");
  Expected<std::string> file = string(spec->at("file"), place + ".file");
  if (!file) return file.error();
  Expected<std::string> resolved = existingFile(*file, place + ".file");
  if (!resolved) return resolved.error();
  Expected<std::shared_ptr<const Texture>> t = textures_.file(*resolved, colour, path_, place);
  if (!t) return t.error();
  TextureBinding b;
  b.texture = *t;
  if (spec->contains("uv_set")) {
    const json& v = spec->at("uv_set");
    if (!v.is_number_integer() || v.get<int64_t>() < 0 || v.get<int64_t>() > 7) {
      return error(place + ".uv_set", "must be an integer from 0 to 7");
    }
    b.uv_set = uint32_t(v.get<int64_t>());
  }
  if (spec->contains("wrap")) {
    Expected<std::string> w = string(spec->at("wrap"), place + ".wrap");
    if (!w) return w.error();
    if (*w == "repeat") {
      b.sampler.wrap_s = b.sampler.wrap_t = TextureWrap::kRepeat;
    } else if (*w == "clamp") {
      b.sampler.wrap_s = b.sampler.wrap_t = TextureWrap::kClampToEdge;
    } else if (*w == "mirror") {
      b.sampler.wrap_s = b.sampler.wrap_t = TextureWrap::kMirroredRepeat;
    } else {
      return error(place + ".wrap", fmt::format("'{}' is not repeat, clamp or mirror", *w));
    }
  }
  if (spec->contains("filter")) {
    Expected<std::string> f = string(spec->at("filter"), place + ".filter");
    if (!f) return f.error();
    if (*f != "linear" && *f != "nearest") {
      return error(place + ".filter", fmt::format("'{}' is not linear or nearest", *f));
    }
    b.sampler.nearest = *f == "nearest";
  }
  PENUMBRA_TRY(readTextureTransform(*spec, path_, place, b));
  return b;
}

Status SceneJsonReader::readCoverage(const json& entry, const std::string& place, Material& m) {
  if (entry.contains("alpha")) {
    Expected<double> a = number(entry.at("alpha"), place + ".alpha");
    if (!a) return a.error();
    if (!(*a >= 0.0 && *a <= 1.0)) return error(place + ".alpha", "must be in [0, 1]");
    m.alpha = float(*a);
  }
  if (entry.contains("alpha_cutoff")) {
    Expected<double> a = number(entry.at("alpha_cutoff"), place + ".alpha_cutoff");
    if (!a) return a.error();
    if (!(*a >= 0.0 && *a <= 1.0)) return error(place + ".alpha_cutoff", "must be in [0, 1]");
    m.alpha_cutoff = float(*a);
  }
  if (entry.contains("coverage_texture")) {
    Expected<TextureBinding> b =
        readTexture(entry.at("coverage_texture"), place + ".coverage_texture", false);
    if (!b) return b.error();
    m.coverage_texture = std::move(*b);
  }
  if (entry.contains("alpha_mode")) {
    Expected<std::string> mode = string(entry.at("alpha_mode"), place + ".alpha_mode");
    if (!mode) return mode.error();
    if (*mode == "opaque") {
      m.alpha_mode = AlphaMode::kOpaque;
    } else if (*mode == "mask") {
      m.alpha_mode = AlphaMode::kMask;
    } else if (*mode == "blend") {
      m.alpha_mode = AlphaMode::kBlend;
    } else {
      return error(place + ".alpha_mode", fmt::format("'{}' is not opaque, mask or blend", *mode));
    }
  } else if (m.coverage_texture || m.alpha < 1.0f) {
    // Coverage given without a mode: a mask for a texture, partial for a constant.
    m.alpha_mode = m.coverage_texture ? AlphaMode::kMask : AlphaMode::kBlend;
  }
  return {};
}

Status SceneJsonReader::readMaterial(const json& entry, const std::string& place,
                                     const std::string& name, bool named, Scene& scene) {
  if (!entry.is_object()) {
    return error(place, fmt::format("must be an object, not {}", jsonTypeName(entry)));
  }
  if (named) {
    PENUMBRA_TRY(
        checkKeys(entry, place,
                  {"name", "type", "reflectance", "specular", "ior", "emission", "two_sided",
                   "subsurface", "normal_map", "normal_scale", "reflectance_texture",
                   "emission_texture", "alpha", "alpha_mode", "alpha_cutoff", "coverage_texture"}));
  } else {
    PENUMBRA_TRY(
        checkKeys(entry, place,
                  {"type", "reflectance", "specular", "ior", "emission", "two_sided", "subsurface",
                   "normal_map", "normal_scale", "reflectance_texture", "emission_texture", "alpha",
                   "alpha_mode", "alpha_cutoff", "coverage_texture"}));
  }
  Material m;
  m.name = name;
  PENUMBRA_TRY(readScattering(entry, place, m));
  if (entry.contains("reflectance")) {
    Expected<glm::vec3> r = colour(entry.at("reflectance"), place + ".reflectance", true);
    if (!r.ok()) return r.error();
    m.reflectance = *r;
  }
  if (entry.contains("emission")) {
    Expected<glm::vec3> e = colour(entry.at("emission"), place + ".emission", false);
    if (!e.ok()) return e.error();
    m.emission = *e;
  }
  if (entry.contains("reflectance_texture")) {
    Expected<TextureBinding> b =
        readTexture(entry.at("reflectance_texture"), place + ".reflectance_texture", true);
    if (!b) return b.error();
    m.reflectance_texture = std::move(*b);
    if (!entry.contains("reflectance")) m.reflectance = glm::vec3(1.0f);
  }
  if (entry.contains("emission_texture")) {
    Expected<TextureBinding> b =
        readTexture(entry.at("emission_texture"), place + ".emission_texture", true);
    if (!b) return b.error();
    m.emission_texture = std::move(*b);
    if (!entry.contains("emission")) m.emission = glm::vec3(1.0f);
  }
  PENUMBRA_TRY(readCoverage(entry, place, m));
  if (entry.contains("two_sided")) {
    if (!entry.at("two_sided").is_boolean()) {
      return error(place + ".two_sided", fmt::format("must be true or false, not {}",
                                                     jsonTypeName(entry.at("two_sided"))));
    }
    m.two_sided = entry.at("two_sided").get<bool>();
  }
  if (entry.contains("normal_map")) {
    Expected<std::string> file = string(entry.at("normal_map"), place + ".normal_map");
    if (!file) return file.error();
    Expected<std::string> resolved = existingFile(*file, place + ".normal_map");
    if (!resolved) return resolved.error();
    Expected<std::shared_ptr<const Image>> map =
        textures_.normalMapFile(*resolved, path_, place + ".normal_map");
    if (!map) return map.error();
    m.normal_map = *map;
    m.normal_map_source = *resolved;
  }
  if (entry.contains("normal_scale")) {
    Expected<double> scale = number(entry.at("normal_scale"), place + ".normal_scale");
    if (!scale) return scale.error();
    if (!(*scale >= 0.0 && *scale <= 100.0)) {
      return error(place + ".normal_scale", fmt::format("{} is outside [0, 100]", *scale));
    }
    m.normal_scale = float(*scale);
  }
  if (entry.contains("subsurface")) {
    Expected<Subsurface> s = parseSubsurface(entry.at("subsurface"), path_, place + ".subsurface");
    if (!s.ok()) return s.error();
    m.subsurface = *s;
    // Methods without subsurface transport see the medium as the Lambertian surface that
    // returns as much diffuse light, unless the scene says otherwise.
    if (!entry.contains("reflectance")) {
      m.reflectance = glm::vec3(glm::clamp(lambertianAlbedo(*s), 0.0, 1.0));
    }
  }
  material_index_[m.name] = static_cast<uint32_t>(scene.materials.size());
  scene.materials.push_back(std::move(m));
  return {};
}

Status SceneJsonReader::readScattering(const json& entry, const std::string& place, Material& m) {
  if (entry.contains("type")) {
    Expected<std::string> type = string(entry.at("type"), place + ".type");
    if (!type) return type.error();
    if (*type == "mirror") {
      m.scattering = Scattering::kMirror;
    } else if (*type == "glass") {
      m.scattering = Scattering::kDielectric;
    } else if (*type != "diffuse") {
      return error(place + ".type",
                   fmt::format("unknown type '{}' (diffuse, mirror or glass)", *type));
    }
  }
  const char* kind = m.scattering == Scattering::kMirror ? "a mirror" : "glass";
  if (!m.isSpecular()) {
    for (const char* key : {"specular", "ior"}) {
      if (entry.contains(key)) {
        return error(place + "." + key, "applies to \"type\": \"mirror\" or \"glass\" only");
      }
    }
    return {};
  }
  if (entry.contains("reflectance")) {
    return error(
        place + ".reflectance",
        fmt::format("{} has no diffuse reflectance: give its colour as \"specular\"", kind));
  }
  if (entry.contains("subsurface")) {
    return error(place + ".subsurface", fmt::format("{} cannot have a subsurface medium", kind));
  }
  if (entry.contains("specular")) {
    Expected<glm::vec3> c = colour(entry.at("specular"), place + ".specular", true);
    if (!c.ok()) return c.error();
    m.specular = *c;
  }
  if (entry.contains("ior")) {
    if (m.scattering != Scattering::kDielectric) {
      return error(place + ".ior", "applies to \"type\": \"glass\" only");
    }
    Expected<double> ior = number(entry.at("ior"), place + ".ior");
    if (!ior) return ior.error();
    if (!(*ior >= 1.0 && *ior <= 4.0)) {
      return error(place + ".ior", fmt::format("{} is outside [1, 4]", *ior));
    }
    m.ior = float(*ior);
  }
  m.reflectance = diffuseStandIn(m);
  return {};
}

Expected<Placement> SceneJsonReader::readTransform(const json& t, const std::string& place) const {
  if (!t.is_object()) {
    return error(place, fmt::format("must be an object, not {}", jsonTypeName(t)));
  }
  PENUMBRA_TRY(checkKeys(t, place, {"scale", "rotate_deg", "translate", "matrix"}));
  Placement out;
  if (t.contains("matrix")) {
    if (t.size() != 1) {
      return error(place, "'matrix' cannot be combined with 'scale', 'rotate_deg' or 'translate'");
    }
    const json& m = t.at("matrix");
    const std::string mplace = place + ".matrix";
    if (!m.is_array() || m.size() != 16) {
      return error(mplace, fmt::format("must be an array of 16 numbers (row-major), not {}",
                                       m.is_array() ? std::to_string(m.size()) : jsonTypeName(m)));
    }
    glm::dmat4 w(1.0);
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) {
        Expected<double> x =
            number(m[static_cast<size_t>(4 * r + c)], fmt::format("{}[{}]", mplace, 4 * r + c));
        if (!x.ok()) return x.error();
        w[c][r] = *x;  // glm is column-major
      }
    }
    if (w[0][3] != 0.0 || w[1][3] != 0.0 || w[2][3] != 0.0 || w[3][3] != 1.0) {
      return error(mplace, "the last row must be [0, 0, 0, 1] (an affine transform)");
    }
    out.world_from_object = w;
  } else {
    glm::dvec3 scale(1.0), rotate(0.0), translate(0.0);
    if (t.contains("scale")) {
      const json& s = t.at("scale");
      if (s.is_number()) {
        Expected<double> x = number(s, place + ".scale");
        if (!x.ok()) return x.error();
        scale = glm::dvec3(*x);
      } else {
        Expected<glm::dvec3> v = vec3(s, place + ".scale");
        if (!v.ok()) {
          return error(
              place + ".scale",
              fmt::format("must be a number or an array of 3 numbers, not {}",
                          s.is_array() ? std::to_string(s.size()) + " numbers" : jsonTypeName(s)));
        }
        scale = *v;
      }
    }
    if (t.contains("rotate_deg")) {
      Expected<glm::dvec3> v = vec3(t.at("rotate_deg"), place + ".rotate_deg");
      if (!v.ok()) return v.error();
      rotate = glm::radians(*v);
    }
    if (t.contains("translate")) {
      Expected<glm::dvec3> v = vec3(t.at("translate"), place + ".translate");
      if (!v.ok()) return v.error();
      translate = *v;
    }
    auto rotation = [](double angle, int axis) {
      const double c = std::cos(angle), s = std::sin(angle);
      const int a = (axis + 1) % 3, b = (axis + 2) % 3;
      glm::dmat4 r(1.0);
      r[a][a] = c;
      r[a][b] = s;
      r[b][a] = -s;
      r[b][b] = c;
      return r;  // right-handed rotation about `axis`
    };
    glm::dmat4 s(1.0), tr(1.0);
    s[0][0] = scale.x;
    s[1][1] = scale.y;
    s[2][2] = scale.z;
    tr[3] = glm::dvec4(translate, 1.0);
    // Scale, then rotate about X, then Y, then Z, then translate.
    out.world_from_object =
        tr * rotation(rotate.z, 2) * rotation(rotate.y, 1) * rotation(rotate.x, 0) * s;
  }
  const double det = glm::determinant(glm::dmat3(out.world_from_object));
  if (!(std::abs(det) > 0.0) || !std::isfinite(det)) {
    return error(place, "the transform is singular (a zero scale?)");
  }
  return out;
}

// A light of a mesh file, placed in the world.
void placeLight(const Placement& placement, Light& light) {
  std::visit(
      Overloaded{[&](PointLight& l) { l.position = placement.point(l.position); },
                 [&](SpotLight& l) {
                   l.position = placement.point(l.position);
                   l.direction = placement.direction(l.direction);
                 },
                 [&](DirectionalLight& l) { l.direction = placement.direction(l.direction); },
                 [&](LuminaireLight& l) {
                   l.position = placement.point(l.position);
                   l.nadir = placement.direction(l.nadir);
                   // C0 kept perpendicular to the nadir under any linear map.
                   const glm::vec3 c0 = placement.direction(l.c0);
                   l.c0 = glm::normalize(c0 - glm::dot(c0, l.nadir) * l.nadir);
                 }},
      light);
}

// The meshes, materials, lights, camera and warnings of a mesh entry's scene `sub`, placed in
// the world and added to `scene`.
void addPlacedScene(const MeshEntry& m, Scene& sub, Scene& scene) {
  const Placement& placement = m.placement;
  // To world space. A mirroring transform flips the winding so that front faces stay front.
  const glm::dmat3 linear(placement.world_from_object);
  const glm::dmat3 normal_from_object = glm::transpose(glm::inverse(linear));
  const bool mirrored = glm::determinant(linear) < 0.0;
  const uint32_t material_base = static_cast<uint32_t>(scene.materials.size());
  const std::string stem = m.sphere_level >= 0 ? std::string("sphere")
                                               : std::filesystem::path(m.resolved).stem().string();
  for (size_t k = 0; k < sub.meshes.size(); ++k) {
    Mesh& mesh = sub.meshes[k];
    for (glm::vec3& p : mesh.positions) p = placement.point(p);
    for (glm::vec3& n : mesh.normals) {
      const glm::dvec3 w = normal_from_object * glm::dvec3(n);
      const double len = glm::length(w);
      n = len > 0.0 ? glm::vec3(w / len) : glm::vec3(0.0f);
    }
    if (mirrored) {
      for (glm::uvec3& t : mesh.triangles) std::swap(t.y, t.z);
    }
    for (uint32_t& id : mesh.material_ids) id = m.material ? *m.material : id + material_base;
    if (!m.name.empty()) {
      mesh.name = sub.meshes.size() == 1 ? m.name : m.name + "/" + mesh.name;
    } else if (mesh.name.empty()) {
      mesh.name = stem;
    }
    scene.meshes.push_back(std::move(mesh));
  }
  if (!m.material) {
    for (Material& material : sub.materials) scene.materials.push_back(std::move(material));
  }
  for (Light& light : sub.lights) {
    placeLight(placement, light);
    scene.lights.push_back(light);
  }
  if (sub.camera && !scene.camera) {
    Camera cam = *sub.camera;
    cam.position = placement.point(cam.position);
    cam.look_at = placement.point(cam.look_at);
    cam.up = placement.direction(cam.up);
    scene.camera = cam;
  }
  for (std::string& w : sub.warnings) {
    scene.warnings.push_back(w.starts_with(m.resolved) ? std::move(w) : m.resolved + ": " + w);
  }
}

Status SceneJsonReader::readMesh(const json& entry, const std::string& place, Scene& scene) {
  if (!entry.is_object()) {
    return error(place, fmt::format("must be an object, not {}", jsonTypeName(entry)));
  }
  PENUMBRA_TRY(checkKeys(entry, place, {"file", "sphere", "material", "transform", "name"}));
  MeshEntry m;
  PENUMBRA_TRY(readMeshSource(entry, place, m));
  PENUMBRA_TRY(readMeshOptions(entry, place, m));

  Expected<Scene> loaded = Scene{};
  if (m.sphere_level >= 0) {
    // A unit sphere, placed by the transform; grey 0.8 unless a material is given.
    loaded->source = path_;
    loaded->meshes.push_back(icosphere(m.sphere_level));
    loaded->materials.push_back(Material{"sphere", glm::vec3(0.8f), glm::vec3(0.0f)});
  } else {
    loaded = loadSceneFile(m.resolved, options_);
    if (!loaded.ok()) return loaded.error();  // names the mesh file and the place in it
  }
  addPlacedScene(m, *loaded, scene);
  return {};
}

Status SceneJsonReader::planSpheres(const json& meshes) const {
  uint64_t triangles = 0, spheres = 0;
  for (const json& entry : meshes) {
    if (!entry.is_object() || !entry.contains("sphere")) continue;
    const json& level = entry.at("sphere");
    if (!level.is_number_integer() || level.get<int64_t>() < 0 ||
        level.get<int64_t>() > kMaxSphereSubdivisions) {
      continue;  // readMeshSource names the entry
    }
    triangles += icosphereTriangles(int(level.get<int64_t>()));
    ++spheres;
  }
  if (spheres == 0) return {};
  Status fits =
      checkMemory(triangles * kSceneBytesPerTriangle,
                  fmt::format("making {} spheres of {} triangles in all", spheres, triangles));
  if (!fits.ok()) return error("meshes", fits.error().message);
  return {};
}

Status SceneJsonReader::readMeshSource(const json& entry, const std::string& place,
                                       MeshEntry& m) const {
  if (entry.contains("file") == entry.contains("sphere")) {
    return error(place, entry.contains("file") ? "give \"file\" or \"sphere\", not both"
                                               : "needs \"file\" (a mesh file) or \"sphere\"");
  }
  if (entry.contains("sphere")) {
    const json& level = entry.at("sphere");
    if (!level.is_number_integer() || level.get<int64_t>() < 0 ||
        level.get<int64_t>() > kMaxSphereSubdivisions) {
      return error(place + ".sphere",
                   fmt::format("must be a subdivision level, an integer in [0, {}], not {}",
                               kMaxSphereSubdivisions, level.dump()));
    }
    m.sphere_level = int(level.get<int64_t>());
    return {};
  }
  Expected<std::string> file = string(entry.at("file"), place + ".file");
  if (!file.ok()) return file.error();
  m.resolved = resolveRelativeTo(path_, *file);
  const std::string ext = extensionOf(m.resolved);
  if (ext != ".obj" && ext != ".gltf" && ext != ".glb" && ext != ".ply") {
    return error(place + ".file",
                 fmt::format("'{}': a mesh file must be .obj, .gltf, .glb or .ply", *file));
  }
  PENUMBRA_TRY(existingFile(*file, place + ".file"));
  return {};
}

Status SceneJsonReader::readMeshOptions(const json& entry, const std::string& place,
                                        MeshEntry& m) const {
  if (entry.contains("material")) {
    Expected<std::string> name = string(entry.at("material"), place + ".material");
    if (!name.ok()) return name.error();
    auto it = material_index_.find(*name);
    if (it == material_index_.end()) {
      return error(place + ".material",
                   fmt::format("material '{}' is not defined in \"materials\"", *name));
    }
    m.material = it->second;
  }
  if (entry.contains("transform")) {
    Expected<Placement> p = readTransform(entry.at("transform"), place + ".transform");
    if (!p.ok()) return p.error();
    m.placement = *p;
  }
  if (entry.contains("name")) {
    Expected<std::string> n = string(entry.at("name"), place + ".name");
    if (!n.ok()) return n.error();
    m.name = *n;
  }
  return {};
}

Status SceneJsonReader::readLight(const json& entry, const std::string& place, Scene& scene) {
  if (!entry.is_object()) {
    return error(place, fmt::format("must be an object, not {}", jsonTypeName(entry)));
  }
  if (!entry.contains("type")) return error(place + ".type", "missing");
  Expected<std::string> type = string(entry.at("type"), place + ".type");
  if (!type.ok()) return type.error();
  auto required = [&](const char* key) -> Expected<const json*> {
    auto it = entry.find(key);
    if (it == entry.end()) return error(keyPath(place, key), "missing");
    return &*it;
  };
  auto point3 = [&](const char* key) -> Expected<glm::vec3> {
    Expected<const json*> j = required(key);
    if (!j.ok()) return j.error();
    Expected<glm::dvec3> v = vec3(**j, keyPath(place, key));
    if (!v.ok()) return v.error();
    return glm::vec3(*v);
  };
  auto colour3 = [&](const char* key) -> Expected<glm::vec3> {
    Expected<const json*> j = required(key);
    if (!j.ok()) return j.error();
    return colour(**j, keyPath(place, key), false);
  };
  auto direction3 = [&](const char* key) -> Expected<glm::vec3> {
    Expected<const json*> j = required(key);
    if (!j.ok()) return j.error();
    return unitDirection(**j, keyPath(place, key));
  };

  if (*type == "point") {
    PENUMBRA_TRY(checkKeys(entry, place, {"type", "position", "intensity"}));
    PointLight l;
    Expected<glm::vec3> p = point3("position");
    if (!p.ok()) return p.error();
    Expected<glm::vec3> i = colour3("intensity");
    if (!i.ok()) return i.error();
    l.position = *p;
    l.intensity = *i;
    scene.lights.push_back(l);
  } else if (*type == "spot") {
    PENUMBRA_TRY(checkKeys(
        entry, place,
        {"type", "position", "direction", "intensity", "inner_angle_deg", "outer_angle_deg"}));
    SpotLight l;
    Expected<glm::vec3> p = point3("position");
    if (!p.ok()) return p.error();
    Expected<glm::vec3> d = direction3("direction");
    if (!d.ok()) return d.error();
    Expected<glm::vec3> i = colour3("intensity");
    if (!i.ok()) return i.error();
    l.position = *p;
    l.direction = *d;
    l.intensity = *i;
    double inner = glm::degrees(static_cast<double>(l.inner_angle));
    double outer = glm::degrees(static_cast<double>(l.outer_angle));
    if (entry.contains("inner_angle_deg")) {
      Expected<double> x = number(entry.at("inner_angle_deg"), place + ".inner_angle_deg");
      if (!x.ok()) return x.error();
      inner = *x;
    }
    if (entry.contains("outer_angle_deg")) {
      Expected<double> x = number(entry.at("outer_angle_deg"), place + ".outer_angle_deg");
      if (!x.ok()) return x.error();
      outer = *x;
    }
    if (!(inner >= 0.0 && inner < outer && outer <= 90.0)) {
      return error(place, fmt::format("spot angles need 0 <= inner_angle_deg < outer_angle_deg "
                                      "<= 90 (got {} and {})",
                                      inner, outer));
    }
    l.inner_angle = static_cast<float>(glm::radians(inner));
    l.outer_angle = static_cast<float>(glm::radians(outer));
    scene.lights.push_back(l);
  } else if (*type == "directional") {
    PENUMBRA_TRY(checkKeys(entry, place, {"type", "direction", "irradiance"}));
    DirectionalLight l;
    Expected<glm::vec3> d = direction3("direction");
    if (!d.ok()) return d.error();
    Expected<glm::vec3> e = colour3("irradiance");
    if (!e.ok()) return e.error();
    l.direction = *d;
    l.irradiance = *e;
    scene.lights.push_back(l);
  } else if (*type == "luminaire") {
    return readLuminaire(entry, place, scene);
  } else {
    return error(place + ".type", fmt::format("unknown light type '{}' (known: point, spot, "
                                              "directional, luminaire)",
                                              *type));
  }
  return {};
}

Status SceneJsonReader::readLuminaire(const json& entry, const std::string& place, Scene& scene) {
  PENUMBRA_TRY(checkKeys(entry, place,
                         {"type", "file", "position", "aim", "rotation_deg", "dimming", "flux_lm",
                          "lamps", "colour", "tilt_deg", "array"}));
  if (!entry.contains("file")) return error(place + ".file", "missing");
  if (!entry.contains("position")) return error(place + ".position", "missing");
  Expected<std::string> file = string(entry.at("file"), place + ".file");
  if (!file) return file.error();
  Expected<const LuminaireData*> data = luminaireData(entry, place, *file);
  if (!data) return data.error();
  const Photometry& photometry = (*data)->first;
  const std::shared_ptr<const LuminaireDistribution>& distribution = (*data)->second;

  Expected<glm::dvec3> position = vec3(entry.at("position"), place + ".position");
  if (!position) return position.error();
  LuminaireLight l;
  PENUMBRA_TRY(readLuminaireAim(entry, place, l));
  Expected<double> factor = luminaireFactor(entry, place, *file, photometry, *distribution);
  if (!factor) return factor.error();
  glm::vec3 tint(1.0f);
  if (entry.contains("colour")) {
    Expected<glm::vec3> c = colour(entry.at("colour"), place + ".colour", false);
    if (!c) return c.error();
    tint = *c;
  }
  l.distribution = distribution;
  l.scale = tint * float(distribution->max_candela / kLumensPerWatt * *factor);

  LuminaireArray array;
  if (entry.contains("array")) PENUMBRA_TRY(readLuminaireArray(entry.at("array"), place, array));
  const int nx = array.nx, nz = array.nz;
  const double dx = array.dx, dz = array.dz;
  // Counted over the scene before any is made: many entries of large arrays add up.
  if (scene.lights.size() + size_t(nx) * size_t(nz) > kMaxSceneLights) {
    return error(entry.contains("array") ? place + ".array" : place,
                 fmt::format("{} more luminaires make {} lights in the scene; a scene holds at "
                             "most {}",
                             size_t(nx) * size_t(nz), scene.lights.size() + size_t(nx) * nz,
                             kMaxSceneLights));
  }
  for (int i = 0; i < nx; ++i) {
    for (int k = 0; k < nz; ++k) {
      LuminaireLight li = l;
      li.position = glm::vec3(
          *position + glm::dvec3((i - 0.5 * (nx - 1)) * dx, 0.0, (k - 0.5 * (nz - 1)) * dz));
      scene.lights.push_back(li);
    }
  }
  return {};
}

Expected<double> SceneJsonReader::optionalNumber(const json& entry, const std::string& place,
                                                 const char* key, double fallback) const {
  if (!entry.contains(key)) return fallback;
  return number(entry.at(key), keyPath(place, key));
}

Expected<const SceneJsonReader::LuminaireData*> SceneJsonReader::luminaireData(
    const json& entry, const std::string& place, const std::string& file) {
  Expected<std::string> found = existingFile(file, place + ".file");
  if (!found) return found.error();
  const std::string resolved = *found;
  Expected<double> tilt = optionalNumber(entry, place, "tilt_deg", 0.0);
  if (!tilt) return tilt.error();
  // One read and one LDT per file and tilt, whatever number of entries and arrays use them.
  const auto key = std::make_pair(resolved, *tilt);
  auto known = luminaires_.find(key);
  if (known == luminaires_.end()) {
    Expected<Photometry> read = readPhotometry(resolved);
    if (!read) return read.error();
    Expected<std::shared_ptr<const LuminaireDistribution>> ldt =
        luminaireDistribution(*read, *tilt);
    if (!ldt) return ldt.error();
    known = luminaires_.emplace(key, std::make_pair(std::move(*read), *ldt)).first;
  }
  return &known->second;
}

Status SceneJsonReader::readLuminaireAim(const json& entry, const std::string& place,
                                         LuminaireLight& l) const {
  glm::vec3 aim(0.0f, -1.0f, 0.0f);
  if (entry.contains("aim")) {
    Expected<glm::vec3> a = unitDirection(entry.at("aim"), place + ".aim");
    if (!a) return a.error();
    aim = *a;
  }
  // C0: world +x made perpendicular to the aim (+z when the aim is along x), turned by
  // rotation_deg anticlockwise seen from behind the luminaire (towards C90).
  const glm::vec3 ref =
      std::abs(aim.x) > 0.99f ? glm::vec3(0.0f, 0.0f, 1.0f) : glm::vec3(1.0f, 0.0f, 0.0f);
  glm::vec3 c0 = glm::normalize(ref - glm::dot(ref, aim) * aim);
  Expected<double> rotation = optionalNumber(entry, place, "rotation_deg", 0.0);
  if (!rotation) return rotation.error();
  const double r = glm::radians(*rotation);
  c0 = glm::normalize(float(std::cos(r)) * c0 + float(std::sin(r)) * glm::cross(c0, aim));
  l.nadir = aim;
  l.c0 = c0;
  return {};
}

Expected<double> SceneJsonReader::luminaireFactor(const json& entry, const std::string& place,
                                                  const std::string& file,
                                                  const Photometry& photometry,
                                                  const LuminaireDistribution& distribution) const {
  double factor = 1.0;
  Expected<double> dimming = optionalNumber(entry, place, "dimming", 1.0);
  if (!dimming) return dimming.error();
  if (!(*dimming >= 0.0 && *dimming <= 1.0)) {
    return error(place + ".dimming", fmt::format("{} is outside [0, 1]", *dimming));
  }
  factor *= *dimming;
  if (entry.contains("lamps")) {
    Expected<double> lamps = number(entry.at("lamps"), place + ".lamps");
    if (!lamps) return lamps.error();
    const int stated =
        photometry.lamps.empty() ? photometry.lamp_count : photometry.lamps.front().count;
    if (!(*lamps >= 1.0 && *lamps == std::floor(*lamps) && *lamps <= 1000.0)) {
      return error(place + ".lamps",
                   fmt::format("{} is not a whole number from 1 to 1000", *lamps));
    }
    if (stated <= 0 || photometry.lamp_flux < 0.0) {
      return error(place + ".lamps",
                   fmt::format("{} gives absolute photometry (no lamp count to scale from)", file));
    }
    factor *= *lamps / stated;
  }
  if (entry.contains("flux_lm")) {
    Expected<double> flux = number(entry.at("flux_lm"), place + ".flux_lm");
    if (!flux) return flux.error();
    if (!(*flux > 0.0 && *flux < 1e9)) {
      return error(place + ".flux_lm", fmt::format("{} lm must be positive and below 1e9", *flux));
    }
    factor *= *flux / distribution.flux_lumens;
  }
  return factor;
}

Status SceneJsonReader::readLuminaireArray(const json& a, const std::string& place,
                                           LuminaireArray& array) const {
  const std::string ap = place + ".array";
  PENUMBRA_TRY(checkKeys(a, ap, {"count", "spacing"}));
  if (!a.contains("count") || !a.at("count").is_array() || a.at("count").size() != 2) {
    return error(ap + ".count", "must be [nx, nz]");
  }
  if (!a.contains("spacing") || !a.at("spacing").is_array() || a.at("spacing").size() != 2) {
    return error(ap + ".spacing", "must be [dx, dz] in metres");
  }
  for (int k = 0; k < 2; ++k) {
    Expected<double> n = number(a.at("count")[size_t(k)], fmt::format("{}.count[{}]", ap, k));
    if (!n) return n.error();
    if (!(*n >= 1.0 && *n <= 1000.0 && *n == std::floor(*n))) {
      return error(fmt::format("{}.count[{}]", ap, k),
                   fmt::format("{} is not a whole number from 1 to 1000", *n));
    }
    Expected<double> d = number(a.at("spacing")[size_t(k)], fmt::format("{}.spacing[{}]", ap, k));
    if (!d) return d.error();
    if (!(*d >= 0.0)) {
      return error(fmt::format("{}.spacing[{}]", ap, k), "must not be negative");
    }
    (k == 0 ? array.nx : array.nz) = int(*n);
    (k == 0 ? array.dx : array.dz) = *d;
  }
  if (size_t(array.nx) * size_t(array.nz) > kMaxSceneLights) {
    return error(ap + ".count", fmt::format("{} x {} luminaires: a scene holds at most {}",
                                            array.nx, array.nz, kMaxSceneLights));
  }
  return {};
}

Status SceneJsonReader::readCamera(const json& cam, const std::string& place, Scene& scene) const {
  PENUMBRA_TRY(checkKeys(cam, place, {"position", "look_at", "up", "fov_deg"}));
  Camera c;
  for (const char* key : {"position", "look_at"}) {
    if (!cam.contains(key)) return error(keyPath(place, key), "missing");
  }
  Expected<glm::dvec3> position = vec3(cam.at("position"), place + ".position");
  if (!position.ok()) return position.error();
  Expected<glm::dvec3> look_at = vec3(cam.at("look_at"), place + ".look_at");
  if (!look_at.ok()) return look_at.error();
  glm::dvec3 up(0.0, 1.0, 0.0);
  if (cam.contains("up")) {
    Expected<glm::dvec3> u = vec3(cam.at("up"), place + ".up");
    if (!u.ok()) return u.error();
    up = *u;
  }
  const glm::dvec3 forward = *look_at - *position;
  if (!(glm::length(forward) > 0.0)) return error(place, "position and look_at are the same point");
  if (!(glm::length(glm::cross(forward, up)) > 1e-9 * glm::length(forward) * glm::length(up))) {
    return error(keyPath(place, "up"), "must not be zero or parallel to the view direction");
  }
  c.position = glm::vec3(*position);
  c.look_at = glm::vec3(*look_at);
  c.up = glm::vec3(glm::normalize(up));
  if (cam.contains("fov_deg")) {
    Expected<double> fov = number(cam.at("fov_deg"), place + ".fov_deg");
    if (!fov.ok()) return fov.error();
    if (!(*fov > 0.0 && *fov < 180.0)) {
      return error(place + ".fov_deg", fmt::format("{} is outside (0, 180)", *fov));
    }
    c.vertical_fov = static_cast<float>(glm::radians(*fov));
  }
  scene.camera = c;
  return {};
}

Expected<Scene> SceneJsonReader::read(const json& root) {
  if (!root.is_object()) {
    return error("", fmt::format("the top level must be an object, not {}", jsonTypeName(root)));
  }
  PENUMBRA_TRY(checkKeys(root, "",
                         {"materials", "meshes", "lights", "camera", "settings", "environment",
                          "calculation", "sky", "openings", "scale"}));
  Scene scene;
  scene.source = path_;
  PENUMBRA_TRY(planTextures(root));
  PENUMBRA_TRY(readMaterials(root, scene));

  if (root.contains("meshes")) {
    const json& meshes = root.at("meshes");
    if (!meshes.is_array()) {
      return error("meshes", fmt::format("must be an array, not {}", jsonTypeName(meshes)));
    }
    PENUMBRA_TRY(planSpheres(meshes));
    for (size_t i = 0; i < meshes.size(); ++i) {
      PENUMBRA_TRY(readMesh(meshes[i], fmt::format("meshes[{}]", i), scene));
    }
  }
  if (root.contains("lights")) {
    const json& lights = root.at("lights");
    if (!lights.is_array()) {
      return error("lights", fmt::format("must be an array, not {}", jsonTypeName(lights)));
    }
    for (size_t i = 0; i < lights.size(); ++i) {
      PENUMBRA_TRY(readLight(lights[i], fmt::format("lights[{}]", i), scene));
    }
  }
  if (root.contains("sky")) {
    if (root.contains("environment")) {
      return error("sky", "a scene has a sky or a uniform environment, not both");
    }
    Expected<DaylightSky> daylight = readSky(root.at("sky"), path_, "sky");
    if (!daylight.ok()) return daylight.error();
    scene.sky = daylight->sky;
    if (daylight->sun) scene.lights.push_back(*daylight->sun);
  }
  if (root.contains("openings")) {
    Expected<std::vector<Opening>> openings = readOpenings(root.at("openings"), path_, "openings");
    if (!openings.ok()) return openings.error();
    scene.openings = std::move(*openings);
  }
  Expected<const json*> camera = object(root, "camera", "", false);
  if (!camera.ok()) return camera.error();
  if (*camera) PENUMBRA_TRY(readCamera(**camera, "camera", scene));
  Expected<const json*> settings = object(root, "settings", "", false);
  if (!settings.ok()) return settings.error();
  if (*settings) scene.settings = **settings;
  if (root.contains("environment")) {
    Expected<glm::vec3> env = environment(root.at("environment"), "environment");
    if (!env.ok()) return env.error();
    scene.environment = *env;
  }

  if (root.contains("calculation")) {
    // Read once the meshes are in (a surface object names one); the same reader as --calc.
    Expected<std::vector<CalculationGrid>> objects =
        calculationObjectsFromJson(scene, root.at("calculation"), path_, "calculation");
    if (!objects.ok()) return objects.error();
    scene.calculation = std::move(*objects);
  }
  if (root.contains("scale")) {
    // Metres per unit of the file's lengths (a scene modelled in millimetres: 0.001).
    Expected<double> scale = number(root.at("scale"), "scale");
    if (!scale) return scale.error();
    if (!(*scale >= 1e-6 && *scale <= 1e6)) {
      return error("scale", fmt::format("{} is outside [1e-6, 1e6] metres per unit", *scale));
    }
    scaleScene(scene, *scale);
  }
  // The mesh files were validated by their loaders, whose warnings (degenerate triangles) name
  // the mesh file; the merged scene's validation would repeat them, so its warnings are dropped
  // (unless meshes were added from memory, which no loader has seen).
  // What decoding the textures had to say (images reduced to the size limit).
  for (const std::string& w : textures_.warnings()) scene.warnings.push_back(w);
  const size_t warnings_before = scene.warnings.size();
  if (complete_) complete_(scene);
  PENUMBRA_TRY(checkScene(scene));
  if (!complete_) scene.warnings.resize(warnings_before);
  liftCoplanarEmitters(scene);  // across meshes of different files too, with its warning
  return scene;
}

}  // namespace

Expected<Scene> loadSceneJson(const std::string& path, const SceneLoadOptions& options) {
  Expected<std::string> text = readFile(path);
  if (!text.ok()) return text.error();
  return parseSceneJson(path, *text, {}, options);
}

Expected<Scene> parseSceneJson(const std::string& path, const std::string& text_in,
                               const std::function<void(Scene&)>& complete,
                               const SceneLoadOptions& options) {
  const std::string* text = &text_in;
  PENUMBRA_TRY(checkJsonNesting(path, *text, /*comments=*/true));
  json root;
  try {
    root = json::parse(*text, nullptr, /*allow_exceptions=*/true, /*ignore_comments=*/true);
  } catch (const json::parse_error& e) {
    // e.byte counts the characters read, the offending one included.
    const size_t offset = e.byte > 0 ? e.byte - 1 : 0;
    std::string message = e.what();
    const size_t k = message.find("parse error");
    const size_t colon = k == std::string::npos ? std::string::npos : message.find(": ", k);
    if (colon != std::string::npos) message = message.substr(colon + 2);
    return inputError(path, lineAndColumn(*text, offset), "JSON " + message);
  } catch (const std::exception& e) {
    return inputError(path, "", fmt::format("JSON error: {}", e.what()));
  }
  try {
    SceneJsonReader reader(path, complete, options);
    return reader.read(root);
  } catch (const std::exception& e) {
    // Every access above is checked; this is a safety net so no exception leaves the loader.
    return inputError(path, "", fmt::format("unexpected JSON error: {}", e.what()));
  }
}

json readSceneSettings(const std::string& path) {
  if (extensionOf(path) != ".json") return json();
  Expected<std::string> text = readFile(path);
  if (!text.ok() || !checkJsonNesting(path, *text, /*comments=*/true).ok()) return json();
  const json root = json::parse(*text, nullptr, /*allow_exceptions=*/false,
                                /*ignore_comments=*/true);
  if (!root.is_object() || !root.contains("settings")) return json();
  return root["settings"];
}

Expected<Scene> loadSceneFile(const std::string& path, const SceneLoadOptions& options) {
  const std::string ext = extensionOf(path);
  if (ext == ".json") return loadSceneJson(path, options);
  if (ext == ".obj") return loadObj(path, options);
  if (ext == ".gltf" || ext == ".glb") return loadGltf(path, options);
  if (ext == ".ply") return loadPly(path);
  return inputError(path, "",
                    ext.empty() ? std::string("no file extension: expected .json, .obj, .gltf, "
                                              ".glb or .ply")
                                : fmt::format("unknown scene file type '{}' (expected .json, .obj, "
                                              ".gltf, .glb or .ply)",
                                              ext));
}

Expected<Scene> loadScene(const std::string& name_or_path, const SceneLoadOptions& options) {
  std::error_code ec;
  const bool is_file =
      std::filesystem::exists(name_or_path, ec) && !std::filesystem::is_directory(name_or_path, ec);
  if (!is_file && name_or_path == "sss") return sssBuiltinScene();
  if (!is_file && name_or_path == "lpv") return lpvBuiltinScene();
  if (!is_file) {
    if (const std::optional<SceneAnimation> a = builtinAnimation(name_or_path)) return (*a)(0.0);
  }
  if (std::filesystem::is_directory(name_or_path, ec)) {
    return inputError(name_or_path, "", "is a directory, not a scene file");
  }
  if (!is_file && extensionOf(name_or_path).empty()) return builtinScene(name_or_path);
  return loadSceneFile(name_or_path, options);
}

}  // namespace penumbra
