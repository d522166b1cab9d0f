// glTF materials as Penumbra computes them (docs/scene-format.md, "glTF 2.0"):
//   - metallic-roughness: baseColorFactor x baseColorTexture x COLOR_0 -> reflectance (alpha ->
//     coverage by alphaMode); metallic 1 and roughness 0 -> a mirror of the base colour;
//     KHR_materials_transmission -> smooth glass (KHR_materials_ior), with KHR_materials_volume
//     and an attenuation distance -> a scattering medium; PENUMBRA_materials_subsurface -> one;
//   - KHR_materials_pbrSpecularGlossiness: diffuseFactor x diffuseTexture -> reflectance (the
//     specular-glossiness part is a highlight, which a diffuse solution does not carry);
//   - KHR_materials_unlit: the surface is seen in its base colour and takes no part in the light
//     (Material::unlit);
//   - emissiveFactor x KHR_materials_emissive_strength x emissiveTexture -> emission (radiance,
//     W m^-2 sr^-1);
//   - normalTexture -> a tangent-space normal map (any image format) with its scale.
// A texture's image is its EXT_texture_webp source when it has one, else its plain source; a
// texture whose only image is KTX2 (KHR_texture_basisu), AVIF or DDS, which no Debian library
// decodes, is refused naming the extension and the material. Every image the scene's materials
// use is planned (io/texture_loader.h) before any is decoded: its header read, its memory counted
// once however many slots share it.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/io/texture_loader.h"
#include "penumbra/scene/scene.h"

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace penumbra {

class GltfAsset;

class GltfMaterials {
 public:
  GltfMaterials(GltfAsset& asset, Scene& scene, const TextureOptions& options);

  // Reads the headers of every image the materials `used` (glTF indices) read and checks the
  // memory of all of them together, before any is decoded.
  Status plan(const std::set<int64_t>& used);
  // The scene material of glTF material `index` (-1: the default material), made on first use;
  // `where` names the primitive that asks.
  Expected<uint32_t> material(int64_t index, const std::string& where);
  // What planning and decoding had to say (images reduced to the size limit).
  const std::vector<std::string>& warnings() const { return textures_.warnings(); }

 private:
  // One image a material slot reads: the glTF image, and how.
  struct ImageUse {
    int64_t image = -1;
    TextureKind kind = TextureKind::kColour;
    std::string place;  // the material and slot, for messages
  };
  Status collectImages(int64_t index, std::vector<ImageUse>& uses);
  // The image a texture reads (EXT_texture_webp's first, then its source; KTX2, AVIF and DDS
  // without a fallback refused); `place` names the material slot.
  Expected<int64_t> textureImage(int64_t texture, const std::string& place);
  Expected<TextureBinding> binding(const nlohmann::json& info, bool colour,
                                   const std::string& place);
  Status readSampler(int64_t sampler, TextureBinding& binding);
  Status readBase(const nlohmann::json& gm, const std::string& label, Material& m);
  Status readEmission(const nlohmann::json& gm, const std::string& label, Material& m);
  Status readNormalMap(const nlohmann::json& gm, const std::string& label, Material& m);
  Status readSubsurface(const nlohmann::json& gm, const std::string& place, Material& m);
  Status readSpecular(const nlohmann::json& gm, const std::string& place, Material& m);
  std::string imageName(int64_t image) const;

  GltfAsset& asset_;
  Scene& scene_;
  TextureCache textures_;
  std::map<int64_t, uint32_t> made_;  // glTF material -> scene material
  std::map<int64_t, std::string> image_names_;
  int default_material_ = -1;
};

}  // namespace penumbra
