#include "penumbra/io/gltf/gltf_extensions.h"

#include <nlohmann/json.hpp>

#include <fmt/format.h>

namespace penumbra {

namespace {

using S = ExtensionSupport;

// Khronos and vendor extensions as registered in KhronosGroup/glTF's extensions/2.0 and seen in
// files from Blender, gltfpack, gltf-transform, three.js, Babylon, Unity and Sketchfab.
constexpr GltfExtensionInfo kExtensions[] = {
    {"KHR_lights_punctual", S::kRead, "point, spot and directional lights"},
    {"KHR_materials_emissive_strength", S::kRead, "emission above 1"},
    {"KHR_materials_transmission", S::kRead, "smooth glass (with KHR_materials_volume: a medium)"},
    {"KHR_materials_volume", S::kRead, "with transmission: a scattering medium"},
    {"KHR_materials_ior", S::kRead, "the index of glass and media"},
    {"KHR_materials_pbrSpecularGlossiness", S::kRead, "the diffuse factor and texture as albedo"},
    {"KHR_materials_unlit", S::kRead, "a surface seen in its own colour, outside the light"},
    {"KHR_texture_transform", S::kRead, "UV offset, rotation and scale"},
    {"KHR_mesh_quantization", S::kRead, "integer positions, normals and UVs"},
    {"KHR_draco_mesh_compression", S::kRead, "Draco-compressed primitives"},
    {"EXT_meshopt_compression", S::kRead, "meshopt-compressed buffer views"},
    {"KHR_meshopt_compression", S::kRead, "meshopt-compressed buffer views"},
    {"EXT_mesh_gpu_instancing", S::kRead, "one mesh placed at many transforms"},
    {"EXT_texture_webp", S::kRead, "WebP textures"},
    {"PENUMBRA_materials_subsurface", S::kRead, "translucent media"},
    {"PENUMBRA_lightmap", S::kRead, "a baked lightmap (read back for its UV set)"},
    {"KHR_materials_variants", S::kRead,
     "material variants: the default materials, as a viewer shows before one is chosen"},
    {"KHR_texture_basisu", S::kFallback, "KTX2 (Basis Universal) textures"},
    {"EXT_texture_avif", S::kFallback, "AVIF textures"},
    {"MSFT_texture_dds", S::kFallback, "DDS textures"},
    {"KHR_xmp_json_ld", S::kMetadata, "XMP metadata"},
    {"KHR_xmp", S::kMetadata, "XMP metadata"},
    {"KHR_materials_clearcoat", S::kIgnored, "a clear coat's specular reflection"},
    {"KHR_materials_sheen", S::kIgnored, "the sheen of cloth"},
    {"KHR_materials_specular", S::kIgnored, "the strength and colour of specular reflection"},
    {"KHR_materials_iridescence", S::kIgnored, "thin-film iridescence"},
    {"KHR_materials_anisotropy", S::kIgnored, "anisotropic highlights"},
    {"KHR_materials_dispersion", S::kIgnored, "the dispersion of glass"},
    {"KHR_materials_diffuse_transmission", S::kIgnored,
     "light passing diffusely through thin surfaces (leaves, paper)"},
    {"KHR_animation_pointer", S::kIgnored, "animation of properties (the rest state is read)"},
    {"EXT_lights_image_based", S::kIgnored,
     "image-based lighting (light the scene with --environment or --sky instead)"},
    {"EXT_lights_ies", S::kIgnored, "IES light profiles (describe luminaires in a scene file)"},
    {"MSFT_lod", S::kIgnored, "levels of detail (the finest is read)"},
    {"MSFT_packing_normalRoughnessMetallic", S::kIgnored, "packed normal maps"},
    {"MSFT_packing_occlusionRoughnessMetallic", S::kIgnored, "packed occlusion maps"},
    {"ADOBE_materials_thin_transparency", S::kIgnored, "thin transparent surfaces"},
};

std::vector<std::string> names(const nlohmann::json& root, const char* key) {
  std::vector<std::string> out;
  if (!root.contains(key) || !root[key].is_array()) return out;
  for (const nlohmann::json& n : root[key]) {
    if (n.is_string()) out.push_back(n.get<std::string>());
  }
  return out;
}

}  // namespace

const GltfExtensionInfo* gltfExtension(std::string_view name) {
  for (const GltfExtensionInfo& e : kExtensions) {
    if (e.name == name) return &e;
  }
  return nullptr;
}

Status checkRequiredExtensions(const std::string& path, const nlohmann::json& root) {
  for (const std::string& name : names(root, "extensionsRequired")) {
    const GltfExtensionInfo* e = gltfExtension(name);
    if (e && (e->support == S::kRead || e->support == S::kFallback)) continue;
    return inputError(
        path, "extensionsRequired",
        e ? fmt::format("the file requires {} ({}), which Penumbra does not "
                        "implement",
                        name, e->effect)
          : fmt::format("the file requires {}, an extension Penumbra does not know", name));
  }
  return {};
}

std::vector<std::string> extensionWarnings(const std::string& path, const nlohmann::json& root) {
  std::vector<std::string> out;
  for (const std::string& name : names(root, "extensionsUsed")) {
    const GltfExtensionInfo* e = gltfExtension(name);
    if (!e) {
      out.push_back(
          fmt::format("{}: extension {} is unknown to Penumbra and is ignored", path, name));
    } else if (e->support == S::kIgnored) {
      out.push_back(
          fmt::format("{}: extension {} is not implemented: {} left out", path, name, e->effect));
    }
  }
  return out;
}

}  // namespace penumbra
