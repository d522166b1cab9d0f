// GLSL sources embedded at build time from shaders/ (cmake/EmbedShaders.cmake).
#pragma once

#include <string_view>
#include <vector>

namespace penumbra {

struct EmbeddedShader {
  std::string_view name;  // path under shaders/, e.g. "raytrace/bvh_intersect.comp"
  std::string_view source;
};

const std::vector<EmbeddedShader>& embeddedShaders();

}  // namespace penumbra
