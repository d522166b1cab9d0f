// Welding vertices by exact position: faces of separate meshes, or of a mesh that repeats
// vertices for seams of its own UVs or normals, share a vertex where they touch. Used by the
// charts (adjacency) and the corner shading normals.
#pragma once

#include <glm/vec3.hpp>

#include <cstdint>
#include <span>
#include <vector>

namespace penumbra {

// Per vertex, the id of its position (ids 0, 1, ... in order of first appearance).
std::vector<uint32_t> weldPositions(std::span<const glm::vec3> positions);

}  // namespace penumbra
