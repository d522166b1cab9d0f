// Valid documents for the value targets to start from.
#pragma once

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace penumbra::fuzz {

// An EULUMDAT file from tests/data/photometry (provenance in its README).
inline std::string sampleLdt() {
  std::ifstream in(std::string(PENUMBRA_TEST_DATA) + "/photometry/sample_isym1.ldt",
                   std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

inline std::string base64(const std::vector<uint8_t>& bytes) {
  static const char* kDigits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < bytes.size(); i += 3) {
    const uint32_t n = uint32_t(bytes[i]) << 16 |
                       (i + 1 < bytes.size() ? uint32_t(bytes[i + 1]) << 8 : 0) |
                       (i + 2 < bytes.size() ? uint32_t(bytes[i + 2]) : 0);
    out += kDigits[n >> 18 & 63];
    out += kDigits[n >> 12 & 63];
    out += i + 1 < bytes.size() ? kDigits[n >> 6 & 63] : '=';
    out += i + 2 < bytes.size() ? kDigits[n & 63] : '=';
  }
  return out;
}

// A unit quad as Blender's exporter writes one: positions, normals, UVs and indices in one
// embedded buffer; a base-colour texture (a 1 x 1 PNG) with KHR_texture_transform and the PBR
// factors; one node placed by TRS holding the mesh, one by a matrix holding a camera, and one
// holding a KHR_lights_punctual spot.
inline nlohmann::json quadGltf() {
  std::vector<uint8_t> buffer;
  auto put = [&](const auto& v) {
    const auto* b = reinterpret_cast<const uint8_t*>(&v);
    buffer.insert(buffer.end(), b, b + sizeof(v));
  };
  const float positions[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  for (const auto& p : positions) put(p);
  for (int i = 0; i < 4; ++i) put(std::array<float, 3>{0, 0, 1});
  const float uvs[4][2] = {{0, 1}, {1, 1}, {1, 0}, {0, 0}};
  for (const auto& t : uvs) put(t);
  for (uint16_t i : {0, 1, 2, 0, 2, 3}) put(i);
  using nlohmann::json;
  return json{
      {"asset", {{"version", "2.0"}, {"generator", "Khronos glTF Blender I/O"}}},
      {"extensionsUsed", {"KHR_texture_transform", "KHR_lights_punctual"}},
      {"scene", 0},
      {"scenes", {{{"nodes", {0, 1, 2}}}}},
      {"nodes",
       {{{"mesh", 0}, {"translation", {0, 0, 0}}, {"rotation", {0, 0, 0, 1}}, {"scale", {1, 1, 1}}},
        {{"camera", 0}, {"matrix", {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0.5, 0.5, 3, 1}}},
        {{"translation", {0.5, 0.5, 1}},
         {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}}}},
      {"cameras",
       {{{"type", "perspective"},
         {"perspective", {{"yfov", 0.7}, {"aspectRatio", 1.0}, {"znear", 0.01}, {"zfar", 100}}}}}},
      {"extensions",
       {{"KHR_lights_punctual",
         {{"lights",
           {{{"type", "spot"},
             {"color", {1, 1, 1}},
             {"intensity", 10},
             {"spot", {{"innerConeAngle", 0.2}, {"outerConeAngle", 0.6}}}}}}}}}},
      {"materials",
       {{{"name", "quad"},
         {"emissiveFactor", {0, 0, 0}},
         {"alphaMode", "MASK"},
         {"alphaCutoff", 0.5},
         {"pbrMetallicRoughness",
          {{"baseColorFactor", {0.8, 0.8, 0.8, 1}},
           {"metallicFactor", 0},
           {"roughnessFactor", 0.5},
           {"baseColorTexture",
            {{"index", 0},
             {"texCoord", 0},
             {"extensions",
              {{"KHR_texture_transform",
                {{"offset", {0, 0}}, {"scale", {2, 2}}, {"rotation", 0.1}}}}}}}}}}}},
      {"textures", {{{"source", 0}, {"sampler", 0}}}},
      {"samplers",
       {{{"magFilter", 9729}, {"minFilter", 9987}, {"wrapS", 10497}, {"wrapT", 10497}}}},
      {"images",
       {{{"uri",
          "data:image/"
          "png;base64,"
          "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mP8z8BQDwAEhQGAhKmMIQAAAABJRU5E"
          "rkJggg=="}}}},
      {"meshes",
       {{{"primitives",
          {{{"attributes", {{"POSITION", 0}, {"NORMAL", 1}, {"TEXCOORD_0", 2}}},
            {"indices", 3},
            {"material", 0}}}}}}},
      {"accessors",
       {{{"bufferView", 0},
         {"componentType", 5126},
         {"count", 4},
         {"type", "VEC3"},
         {"min", {0, 0, 0}},
         {"max", {1, 1, 0}}},
        {{"bufferView", 1}, {"componentType", 5126}, {"count", 4}, {"type", "VEC3"}},
        {{"bufferView", 2}, {"componentType", 5126}, {"count", 4}, {"type", "VEC2"}},
        {{"bufferView", 3}, {"componentType", 5123}, {"count", 6}, {"type", "SCALAR"}}}},
      {"bufferViews",
       {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 48}},
        {{"buffer", 0}, {"byteOffset", 48}, {"byteLength", 48}},
        {{"buffer", 0}, {"byteOffset", 96}, {"byteLength", 32}},
        {{"buffer", 0}, {"byteOffset", 128}, {"byteLength", 12}}}},
      {"buffers",
       {{{"byteLength", buffer.size()},
         {"uri", "data:application/octet-stream;base64," + base64(buffer)}}}}};
}

}  // namespace penumbra::fuzz
