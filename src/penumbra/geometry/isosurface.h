// A closed triangle mesh of the level set {f = 0} of a scalar field (f > 0 inside), by marching
// tetrahedra on a regular grid: each cube split into six tetrahedra about its main diagonal (the
// same split in every cube, so neighbouring cubes meet without cracks), one or two triangles
// per tetrahedron the surface crosses, vertices on the grid's edges shared between the cubes
// that meet there, every triangle wound outwards (its normal against the field's gradient).
// Used for meshes whose topology changes from frame to frame (merging blobs).
#pragma once

#include "penumbra/scene/scene.h"

#include <glm/vec3.hpp>

#include <functional>

namespace penumbra {

// The surface of f over the box [lo, hi] sampled at `cells` cubes along each axis (the field
// should be negative on the box's boundary for a closed mesh). One material (id 0).
Mesh isosurfaceMesh(const std::function<double(const glm::dvec3&)>& f, const glm::dvec3& lo,
                    const glm::dvec3& hi, int cells);

}  // namespace penumbra
