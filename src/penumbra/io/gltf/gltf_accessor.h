// Accessors (glTF 2.0 sec. 3.6.2 "Accessor Data", 3.6.2.3 "Sparse Accessors") and the storage
// each use of one may have: the core specification's (sec. 3.7.2.1 "Meshes") and
// KHR_mesh_quantization's, which adds integer positions, normals, UVs and morph targets
// (normalized or not; a node's transform then scales them back to metres). Every accessor is
// checked against its buffer view before any pointer is taken: its type and storage for the use,
// byteOffset, byteStride and count. A sparse accessor, or one without a buffer view (all zeros),
// is written out densely, its indices checked to increase strictly and stay below its count.
#pragma once

#include "penumbra/core/expected.h"

#include <cstdint>
#include <initializer_list>
#include <memory>
#include <string>
#include <vector>

namespace penumbra {

class GltfAsset;

// glTF componentType values (sec. 3.6.2.2).
enum : int {
  kGltfByte = 5120,
  kGltfUnsignedByte = 5121,
  kGltfShort = 5122,
  kGltfUnsignedShort = 5123,
  kGltfUnsignedInt = 5125,
  kGltfFloat = 5126,
};

// The elements of an accessor, read in place or from its own dense copy.
struct AccessorView {
  const unsigned char* data = nullptr;  // first element
  size_t stride = 0;                    // bytes between elements
  size_t count = 0;
  int component_type = kGltfFloat;
  int components = 0;  // 1 SCALAR, 2 VEC2, 3 VEC3, 4 VEC4, 16 MAT4
  bool normalized = false;
  std::shared_ptr<const std::string> owned;  // the dense copy `data` points into, if any

  // Component c of element i: a float, a normalized integer mapped to [0, 1] or [-1, 1] (sec.
  // 3.11 "Animations": max(c / (2^(n-1) - 1), -1) for signed ones), or an integer as it is.
  double component(size_t i, int c) const;
  // Element i of an index accessor (unsigned integers).
  uint32_t index(size_t i) const;
};

// A storage an accessor may have for a use.
struct AccessorStorage {
  int component_type = kGltfFloat;
  bool normalized = false;
};

// What a use accepts: its types (component counts) and storages; `quantized` storages are those
// KHR_mesh_quantization adds, accepted when the file uses that extension.
struct AccessorRule {
  std::vector<int> components;
  std::vector<AccessorStorage> core;
  std::vector<AccessorStorage> quantized;
};

// The rules of the attributes Penumbra reads (POSITION, NORMAL, TEXCOORD_n, COLOR_n, JOINTS_n,
// WEIGHTS_n, morph target POSITION and NORMAL, indices, EXT_mesh_gpu_instancing's TRANSLATION,
// ROTATION and SCALE, skins' inverseBindMatrices), by name.
const AccessorRule& accessorRule(const std::string& use);

// Checks that accessor `index` may serve `use` (accessorRule's names): its type and storage;
// `role` names the use in messages ("mesh 0 primitive 1 POSITION").
Status checkAccessorUse(GltfAsset& asset, int64_t index, const std::string& use,
                        const std::string& role);
// Reads accessor `index` for `use`, checked as above and against its buffer view.
Expected<AccessorView> readAccessor(GltfAsset& asset, int64_t index, const std::string& use,
                                    const std::string& role);

// An accessor as KHR_draco_mesh_compression decodes it: `count` elements of `components` values
// of `component_type`, tightly packed in `bytes`.
AccessorView denseAccessor(std::string bytes, size_t count, int components, int component_type,
                           bool normalized);

// Bytes per component of a componentType (0 for an unknown one).
int componentSize(int component_type);
// The number of components of an accessor type ("VEC3" -> 3; 0 for an unknown one).
int componentCount(const std::string& type);

}  // namespace penumbra
