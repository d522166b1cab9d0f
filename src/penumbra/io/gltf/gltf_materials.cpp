#include "penumbra/io/gltf/gltf_materials.h"

#include "penumbra/io/gltf/gltf_asset.h"
#include "penumbra/io/subsurface_json.h"
#include "penumbra/scene/media.h"

#include <nlohmann/json.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace penumbra {

namespace {

using nlohmann::json;

const json& extension(const json& j, const char* name) {
  return member(member(j, "extensions"), name);
}

// The image extensions of textures that name an image Penumbra cannot decode.
constexpr const char* kUndecodable[] = {"KHR_texture_basisu", "EXT_texture_avif",
                                        "MSFT_texture_dds"};

// Whether an image is KTX2, AVIF or DDS by its MIME type or file name.
const char* undecodableKind(const json& image) {
  const std::string mime = image.value("mimeType", std::string());
  const std::string uri = image.contains("uri") ? image["uri"].get<std::string>() : "";
  auto ends = [&](const char* e) {
    const std::string s(e);
    return uri.size() >= s.size() && uri.compare(uri.size() - s.size(), s.size(), s) == 0;
  };
  if (mime == "image/ktx2" || ends(".ktx2") || uri.rfind("data:image/ktx2", 0) == 0) {
    return "KTX2 (KHR_texture_basisu)";
  }
  if (mime == "image/avif" || ends(".avif")) return "AVIF (EXT_texture_avif)";
  if (mime == "image/vnd-ms.dds" || ends(".dds")) return "DDS (MSFT_texture_dds)";
  return nullptr;
}

// The slots of a material that read textures, colour or data, with their textureInfo.
struct Slot {
  const char* name;
  const json* info;
  bool colour;
};

std::vector<Slot> slotsOf(const json& gm) {
  const json& pbr = member(gm, "pbrMetallicRoughness");
  const json& sg = extension(gm, "KHR_materials_pbrSpecularGlossiness");
  std::vector<Slot> out;
  if (sg.is_object()) {
    if (sg.contains("diffuseTexture"))
      out.push_back({"diffuseTexture", &sg["diffuseTexture"], true});
  } else if (pbr.contains("baseColorTexture")) {
    out.push_back({"baseColorTexture", &pbr["baseColorTexture"], true});
  }
  if (gm.contains("emissiveTexture"))
    out.push_back({"emissiveTexture", &gm["emissiveTexture"], true});
  return out;
}

}  // namespace

GltfMaterials::GltfMaterials(GltfAsset& asset, Scene& scene, const TextureOptions& options)
    : asset_(asset), scene_(scene), textures_(options) {}

std::string GltfMaterials::imageName(int64_t image) const {
  auto it = image_names_.find(image);
  return it != image_names_.end() ? it->second : fmt::format("{} image {}", asset_.path(), image);
}

Expected<int64_t> GltfMaterials::textureImage(int64_t texture, const std::string& place) {
  Expected<const json*> t = asset_.entry("textures", texture, place);
  if (!t) return t.error();
  const json& webp = extension(**t, "EXT_texture_webp");
  if (webp.contains("source")) return webp["source"].get<int64_t>();
  const json& tex = **t;
  if (tex.contains("source")) {
    const int64_t source = tex["source"].get<int64_t>();
    Expected<const json*> image = asset_.entry("images", source, place);
    if (!image) return image.error();
    if (const char* kind = undecodableKind(**image)) {
      return inputError(asset_.path(), place,
                        fmt::format("texture {}'s image {} is {}, which Penumbra cannot decode "
                                    "(no Debian library does); give the texture a PNG, JPEG or "
                                    "WebP image",
                                    texture, source, kind));
    }
    return source;
  }
  for (const char* name : kUndecodable) {
    if (extension(tex, name).is_object()) {
      return inputError(asset_.path(), place,
                        fmt::format("texture {} has only a {} image and no fallback source: "
                                    "Penumbra cannot decode that format (no Debian library does)",
                                    texture, name));
    }
  }
  return inputError(asset_.path(), place, fmt::format("texture {} has no image", texture));
}

Status GltfMaterials::collectImages(int64_t index, std::vector<ImageUse>& uses) {
  Expected<const json*> gm = asset_.entry("materials", index, "materials");
  if (!gm) return gm.error();
  const std::string name = valueOr((**gm), "name", std::string());
  const std::string label = fmt::format("material {} ('{}')", index,
                                        name.empty() ? fmt::format("material{}", index) : name);
  for (const Slot& slot : slotsOf(**gm)) {
    const std::string place = label + "." + slot.name;
    Expected<int64_t> image = textureImage(slot.info->at("index").get<int64_t>(), place);
    if (!image) return image.error();
    uses.push_back({*image, slot.colour ? TextureKind::kColour : TextureKind::kData, place});
  }
  const json& normal = member(**gm, "normalTexture");
  if (normal.is_object() && normal.value("texCoord", 0) == 0) {
    const std::string place = label + ".normalTexture";
    Expected<int64_t> image = textureImage(normal["index"].get<int64_t>(), place);
    if (!image) return image.error();
    uses.push_back({*image, TextureKind::kNormalMap, place});
  }
  return {};
}

Status GltfMaterials::plan(const std::set<int64_t>& used) {
  std::vector<ImageUse> uses;
  for (int64_t m : used) {
    if (m >= 0) PENUMBRA_TRY(collectImages(m, uses));
  }
  // The files first: what reading them takes, before any is read.
  std::set<int64_t> images;
  uint64_t file_bytes = 0;
  for (const ImageUse& u : uses) {
    if (!images.insert(u.image).second) continue;
    Expected<GltfAsset::ImageSource> s = asset_.imageSource(u.image, u.place);
    if (!s) return s.error();
    image_names_[u.image] = s->name + (s->file.empty() ? s->extension : "");
    file_bytes += s->bytes;
  }
  PENUMBRA_TRY(textures_.reserveFiles(file_bytes, images.size(), asset_.path()));
  for (const ImageUse& u : uses) {
    Expected<std::string_view> bytes = asset_.imageBytes(u.image, u.place);
    if (!bytes) return bytes.error();
    PENUMBRA_TRY(textures_.plan(imageName(u.image), *bytes, u.kind, asset_.path(),
                                fmt::format("{} (images[{}])", u.place, u.image)));
  }
  return textures_.checkPlan(asset_.path());
}

Expected<TextureBinding> GltfMaterials::binding(const json& info, bool colour,
                                                const std::string& place) {
  const int64_t texture = info.at("index").get<int64_t>();
  Expected<int64_t> image = textureImage(texture, place);
  if (!image) return image.error();
  Expected<std::shared_ptr<const Texture>> t =
      textures_.texture(imageName(*image), colour, asset_.path(), place);
  if (!t) return t.error();
  TextureBinding b;
  b.texture = *t;
  const json& tex = asset_.json()["textures"][size_t(texture)];
  if (tex.contains("sampler")) PENUMBRA_TRY(readSampler(tex["sampler"].get<int64_t>(), b));
  int64_t uv_set = info.value("texCoord", int64_t(0));
  const json& transform = extension(info, "KHR_texture_transform");
  if (transform.is_object()) {
    PENUMBRA_TRY(readTextureTransform(transform, asset_.path(),
                                      place + ".extensions.KHR_texture_transform", b));
    if (transform.contains("texCoord")) uv_set = transform["texCoord"].get<int64_t>();
  }
  if (uv_set < 0 || uv_set > 7) {
    return inputError(asset_.path(), place,
                      fmt::format("texCoord {} is not a UV set Penumbra reads (0 to 7)", uv_set));
  }
  b.uv_set = uint32_t(uv_set);
  return b;
}

Status GltfMaterials::readSampler(int64_t sampler, TextureBinding& b) {
  Expected<const json*> s = asset_.entry("samplers", sampler, "textures");
  if (!s) return s.error();
  auto wrap = [](int mode) {
    switch (mode) {
      case 33071:
        return TextureWrap::kClampToEdge;
      case 33648:
        return TextureWrap::kMirroredRepeat;
      default:
        return TextureWrap::kRepeat;
    }
  };
  b.sampler.wrap_s = wrap((*s)->value("wrapS", 10497));
  b.sampler.wrap_t = wrap((*s)->value("wrapT", 10497));
  b.sampler.nearest = (*s)->value("magFilter", 9729) == 9728;
  return {};
}

Status GltfMaterials::readBase(const json& gm, const std::string& label, Material& m) {
  const json& sg = extension(gm, "KHR_materials_pbrSpecularGlossiness");
  const json& pbr = member(gm, "pbrMetallicRoughness");
  // KHR_materials_pbrSpecularGlossiness: its diffuse colour is the albedo; glTF 2.0's
  // metallic-roughness block, kept for viewers without the extension, is then a fallback.
  const char* factor_key = sg.is_object() ? "diffuseFactor" : "baseColorFactor";
  const json& block = sg.is_object() ? sg : pbr;
  if (block.contains(factor_key)) {
    const json& f = block[factor_key];
    if (!f.is_array() || f.size() != 4) {
      return inputError(asset_.path(), label + "." + factor_key, "needs 4 numbers");
    }
    for (int c = 0; c < 4; ++c) {
      double v = f[size_t(c)].is_number() ? f[size_t(c)].get<double>() : -1.0;
      // Within float32 rounding of [0, 1] (checkGltfValues): clamped.
      if (!(v >= -1e-6 && v <= 1.0 + 1e-6)) {
        return inputError(asset_.path(), label + "." + factor_key, "must be 4 numbers in [0, 1]");
      }
      v = std::clamp(v, 0.0, 1.0);
      if (c < 3) m.reflectance[c] = float(v);
      if (c == 3) m.alpha = float(v);
    }
  } else {
    m.reflectance = glm::vec3(1.0f);
  }
  const char* texture_key = sg.is_object() ? "diffuseTexture" : "baseColorTexture";
  if (block.contains(texture_key)) {
    Expected<TextureBinding> b =
        binding(block[texture_key], true, fmt::format("{}.{}", label, texture_key));
    if (!b) return b.error();
    m.reflectance_texture = std::move(*b);
  }
  const std::string mode = gm.value("alphaMode", std::string("OPAQUE"));
  if (mode == "MASK") {
    m.alpha_mode = AlphaMode::kMask;
    m.alpha_cutoff = gm.value("alphaCutoff", 0.5f);
  } else if (mode == "BLEND") {
    m.alpha_mode = AlphaMode::kBlend;
  } else if (mode != "OPAQUE") {
    return inputError(asset_.path(), label + ".alphaMode",
                      fmt::format("'{}' is not OPAQUE, MASK or BLEND", mode));
  }
  return {};
}

Status GltfMaterials::readEmission(const json& gm, const std::string& label, Material& m) {
  double strength = 1.0;
  const json& es = extension(gm, "KHR_materials_emissive_strength");
  if (es.is_object() && es.contains("emissiveStrength")) {
    const json& s = es["emissiveStrength"];
    if (!s.is_number() || !(s.get<double>() >= 0.0) || !std::isfinite(s.get<double>())) {
      return inputError(asset_.path(),
                        label + ".extensions.KHR_materials_emissive_strength.emissiveStrength",
                        "must be a finite number >= 0");
    }
    strength = s.get<double>();
  }
  if (gm.contains("emissiveFactor")) {
    const json& e = gm["emissiveFactor"];
    // Clamped: checkGltfValues lets float32 rounding past [0, 1] through.
    const glm::dvec3 factor = glm::clamp(
        glm::dvec3(e[0].get<double>(), e[1].get<double>(), e[2].get<double>()), 0.0, 1.0);
    m.emission = glm::vec3(factor * strength);
  }
  if (gm.contains("emissiveTexture")) {
    Expected<TextureBinding> b = binding(gm["emissiveTexture"], true, label + ".emissiveTexture");
    if (!b) return b.error();
    m.emission_texture = std::move(*b);
  }
  return {};
}

Status GltfMaterials::readNormalMap(const json& gm, const std::string& label, Material& m) {
  const json& normal = member(gm, "normalTexture");
  if (!normal.is_object()) return {};
  // Wallner sec. 3.3: a tangent-space normal map on TEXCOORD_0 (scene/material.h).
  const int64_t set = normal.value("texCoord", int64_t(0));
  if (set != 0) {
    scene_.warnings.push_back(
        fmt::format("{}: {}: normalTexture on TEXCOORD_{} is not used (only TEXCOORD_0 is read)",
                    asset_.path(), label, set));
    return {};
  }
  const std::string place = label + ".normalTexture";
  Expected<int64_t> image = textureImage(normal["index"].get<int64_t>(), place);
  if (!image) return image.error();
  Expected<std::shared_ptr<const Image>> map =
      textures_.dataImage(imageName(*image), asset_.path(), place);
  if (!map) return map.error();
  m.normal_map = *map;
  m.normal_map_source = imageName(*image);
  m.normal_scale = normal.value("scale", 1.0f);
  return {};
}

Expected<uint32_t> GltfMaterials::material(int64_t index, const std::string& where) {
  if (index < 0) {
    if (default_material_ < 0) {
      default_material_ = int(scene_.materials.size());
      scene_.materials.push_back(Material{"default", glm::vec3(0.8f), glm::vec3(0.0f)});
    }
    return uint32_t(default_material_);
  }
  auto made = made_.find(index);
  if (made != made_.end()) return made->second;
  Expected<const json*> entry = asset_.entry("materials", index, where);
  if (!entry) return entry.error();
  const json& gm = **entry;
  const std::string place = fmt::format("material {}", index);
  Material m;
  m.name = gm.value("name", std::string());
  if (m.name.empty()) m.name = fmt::format("material{}", index);
  m.two_sided = gm.value("doubleSided", false);
  const std::string label = fmt::format("{} ('{}')", place, m.name);
  PENUMBRA_TRY(readBase(gm, label, m));
  if (extension(gm, "KHR_materials_unlit").is_object()) {
    // Seen in its base colour (times its texture), outside the light (Material::unlit).
    m.unlit = true;
    m.emission = m.reflectance;
    m.emission_texture = m.reflectance_texture;
    m.reflectance = glm::vec3(0.0f);
  } else {
    PENUMBRA_TRY(readEmission(gm, label, m));
    PENUMBRA_TRY(readNormalMap(gm, label, m));
    PENUMBRA_TRY(readSubsurface(gm, place, m));
    if (!m.subsurface) PENUMBRA_TRY(readSpecular(gm, place, m));
  }
  const uint32_t id = uint32_t(scene_.materials.size());
  scene_.materials.push_back(std::move(m));
  made_[index] = id;
  return id;
}

Status GltfMaterials::readSubsurface(const json& gm, const std::string& place, Material& m) {
  const json& own = extension(gm, "PENUMBRA_materials_subsurface");
  if (!own.is_null()) {
    Expected<Subsurface> s =
        parseSubsurface(own, asset_.path(), place + ".extensions.PENUMBRA_materials_subsurface");
    if (!s) return s.error();
    m.subsurface = *s;
  } else {
    const json& v = extension(gm, "KHR_materials_volume");
    if (!v.is_object() || extension(gm, "KHR_materials_transmission").is_null()) return {};
    // A transmissive volume read as a scattering medium: the base colour is the diffuse
    // reflectance it shows, attenuationDistance x attenuationColor how far light diffuses per
    // channel (a subsurface radius), KHR_materials_ior its index (glTF's default 1.5).
    const std::string vplace = place + ".extensions.KHR_materials_volume";
    double distance = std::numeric_limits<double>::infinity();
    glm::dvec3 tint(1.0);
    if (v.contains("attenuationDistance")) {
      if (!v["attenuationDistance"].is_number() ||
          !(v["attenuationDistance"].get<double>() > 0.0)) {
        return inputError(asset_.path(), vplace + ".attenuationDistance",
                          "must be a positive number");
      }
      distance = v["attenuationDistance"].get<double>();
    }
    if (v.contains("attenuationColor")) {
      const json& c = v["attenuationColor"];
      if (!c.is_array() || c.size() != 3) {
        return inputError(asset_.path(), vplace + ".attenuationColor", "needs 3 numbers");
      }
      for (int i = 0; i < 3; ++i) {
        if (!c[size_t(i)].is_number() || !(c[size_t(i)].get<double>() > 0.0)) {
          return inputError(asset_.path(), vplace + ".attenuationColor",
                            "must be positive numbers");
        }
        tint[i] = c[size_t(i)].get<double>();
      }
    }
    if (!std::isfinite(distance)) return {};  // a clear volume: glass (readSpecular)
    double eta = 1.5;
    const json& ior = extension(gm, "KHR_materials_ior");
    if (ior.is_object() && ior.contains("ior")) {
      if (!ior["ior"].is_number()) {
        return inputError(asset_.path(), place + ".extensions.KHR_materials_ior.ior",
                          "must be a number");
      }
      eta = ior["ior"].get<double>();
    }
    const glm::dvec3 albedo = glm::min(glm::dvec3(m.reflectance), glm::dvec3(0.999));
    Expected<Subsurface> s = subsurfaceFromAlbedo(albedo, distance * tint, eta);
    if (!s) return inputError(asset_.path(), vplace, s.error().message);
    m.subsurface = *s;
    scene_.warnings.push_back(
        fmt::format("{}: {} ('{}'): KHR_materials_volume + KHR_materials_transmission read as a "
                    "scattering medium (base colour as its albedo, attenuation distance x colour "
                    "as its diffusion length)",
                    asset_.path(), place, m.name));
  }
  // Methods without subsurface transport see the Lambertian surface that returns as much light.
  m.reflectance = glm::vec3(glm::clamp(lambertianAlbedo(*m.subsurface), 0.0, 1.0));
  return {};
}

Status GltfMaterials::readSpecular(const json& gm, const std::string& place, Material& m) {
  const glm::vec3 base = m.reflectance;
  const json& t = extension(gm, "KHR_materials_transmission");
  if (t.is_object()) {
    const std::string tplace = place + ".extensions.KHR_materials_transmission";
    double factor = 0.0;  // the extension's default
    if (t.contains("transmissionFactor")) {
      const json& f = t["transmissionFactor"];
      if (!f.is_number() || !(f.get<double>() >= 0.0 && f.get<double>() <= 1.0)) {
        return inputError(asset_.path(), tplace + ".transmissionFactor",
                          "must be a number in [0, 1]");
      }
      factor = f.get<double>();
    }
    if (factor > 0.0) {
      // Smooth glass: the base colour filters the light it lets in, KHR_materials_ior gives its
      // index (the extension's default 1.5).
      double ior = 1.5;
      const json& i = extension(gm, "KHR_materials_ior");
      if (i.is_object() && i.contains("ior")) {
        if (!i["ior"].is_number() ||
            !(i["ior"].get<double>() >= 1.0 && i["ior"].get<double>() <= 4.0)) {
          return inputError(asset_.path(), place + ".extensions.KHR_materials_ior.ior",
                            "must be a number in [1, 4]");
        }
        ior = i["ior"].get<double>();
      }
      m.scattering = Scattering::kDielectric;
      m.ior = float(ior);
      m.specular = glm::clamp(base, glm::vec3(0.0f), glm::vec3(1.0f));
      if (factor < 1.0) {
        scene_.warnings.push_back(
            fmt::format("{}: {} ('{}'): transmissionFactor {} read as 1 (smooth glass)",
                        asset_.path(), place, m.name, factor));
      }
      m.reflectance = diffuseStandIn(m);
      return {};
    }
  }
  // A smooth metal: a perfect mirror of the base colour.
  const json& pbr = member(gm, "pbrMetallicRoughness");
  if (extension(gm, "KHR_materials_pbrSpecularGlossiness").is_null() &&
      valueOr(pbr, "metallicFactor", 1.0) == 1.0 && valueOr(pbr, "roughnessFactor", 1.0) == 0.0) {
    m.scattering = Scattering::kMirror;
    m.specular = glm::clamp(base, glm::vec3(0.0f), glm::vec3(1.0f));
    m.reflectance = diffuseStandIn(m);
  }
  return {};
}

}  // namespace penumbra
