// Radiosity elements: the scene's triangles refined into small constant-radiosity patches
// (Carr, Hall, Hart 2003, sec. 3: "constant elements, as are typically used").
//
// Each scene triangle is refined regularly, 1 to 4 (edge midpoints) k times, into 4^k elements
// of equal area; k is chosen per triangle from its area, so elements come out within a factor
// of 2 of a target area everywhere (the target is given directly or as a total element count,
// which is therefore met only approximately). Points on a
// shared edge are computed from the edge's two end points in a fixed order, so neighbouring
// triangles refined to the same level share their vertices exactly (vertices are welded by exact
// position).
//
// Elements are one-sided: an element's radiosity leaves from its front face (the side its
// counter-clockwise winding faces, where emissive materials emit), and light arriving at its
// back is not reflected. Closed scenes whose surfaces face inward (the Cornell box, the furnace,
// architectural models) are what matrix radiosity is for.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/scene/scene.h"

#include <glm/vec3.hpp>

#include <cstdint>
#include <span>
#include <vector>

namespace penumbra {

struct MeshingOptions {
  uint32_t target_elements = 1000;  // about this many elements in all (used when max_area <= 0)
  float max_area = 0.0f;            // or: elements of about this area (m^2)
  int max_level = 10;               // refinement levels per scene triangle (4^10 elements)
};

// Structure of arrays, one entry per element unless stated.
struct Elements {
  // The refined mesh: element e is triangle triangles[e] over positions.
  std::vector<glm::vec3> positions;
  std::vector<glm::uvec3> triangles;
  std::vector<uint32_t> source;    // the scene triangle it refines (flattenScene order)
  std::vector<uint32_t> material;  // Scene::materials index
  std::vector<float> area;         // m^2
  std::vector<glm::vec3> centroid;
  std::vector<glm::vec3> normal;  // unit, the front face's
  // Scene triangles as flattened (what visibility rays are traced against).
  FlatTriangles scene;

  size_t size() const { return triangles.size(); }

  // Values at the element corners for smooth display (sec. 3.1): at each corner, the
  // area-weighted average of the values of the elements that share the vertex and whose normal
  // is within `crease_degrees` of this element's (so the corners of a room stay sharp while a
  // curved surface is smooth). Corner k of element e is entry 3 e + k.
  std::vector<glm::vec3> cornerAverage(std::span<const glm::vec3> per_element,
                                       float crease_degrees = 30.0f) const;
};

// Bytes meshElements() will need for `count` elements (for checks before allocating).
size_t elementBytes(size_t count);

// Refines every non-degenerate triangle of `scene` (which must have passed validateScene).
// Fails when the options ask for no elements or when the elements would not fit in memory.
Expected<Elements> meshElements(const Scene& scene, const MeshingOptions& options);

}  // namespace penumbra
