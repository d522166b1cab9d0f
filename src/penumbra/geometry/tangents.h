// Tangent frames per triangle corner for tangent-space normal maps (Wallner sec. 3.3), built as
// MikkTSpace (Mikkelsen 2008, the convention glTF and Blender bake with) builds them: the
// triangle's tangent and bitangent from the derivatives of its UVs, summed over the corners that
// share a position, a shading normal, a UV and a handedness, each weighted by the triangle's
// angle at the corner, then made orthogonal to the corner's normal (Gram-Schmidt). The
// bitangent is w cross(n, t), w = +1 or -1 the handedness, pointing up the image (the OpenGL /
// glTF "+Y up" normal maps). Not MikkTSpace's code: its degenerate-triangle and
// vertex-splitting corner cases are not reproduced, so frames may differ on such triangles.
#pragma once

#include "penumbra/scene/scene.h"

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <span>
#include <vector>

namespace penumbra {

// Corner k of triangle t at 3 t + k (flattenScene order): xyz the unit tangent (along +u), w the
// handedness. Triangles without UVs, or whose UVs are degenerate, get a tangent perpendicular to
// the normal chosen from the normal alone. `corner_normals` are the shading normals the frames
// are orthogonal to (cornerShadingNormals).
std::vector<glm::vec4> cornerTangents(const Scene& scene,
                                      std::span<const glm::vec3> corner_normals);

// The normal a tangent-space normal map gives: `rgb` as stored in [0, 1], scaled in x and y by
// `scale`, in the frame (t, w cross(n, t), n); unit.
glm::dvec3 perturbedNormal(const glm::dvec3& n, const glm::vec4& tangent, const glm::vec3& rgb,
                           float scale);

// The normal map's value at a mesh UV (bilinear, repeating), for a mesh whose v axis is
// `uv_origin_top` (scene/mesh.h).
glm::vec3 sampleNormalMap(const Image& map, glm::vec2 uv, bool uv_origin_top);

}  // namespace penumbra
