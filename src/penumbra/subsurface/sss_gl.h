// Passes 1 and 2 of the subsurface method (Carr, Hall, Hart 2003, sec. 4.2.2-4.2.3) on the GPU
// (OpenGL 4.5 compute), the twins of SssSolver::transmittedIrradiance and SssSolver::scatter:
//
//  - pass 1 (shaders/subsurface/sss_irradiance.comp): a shadow ray per element and light, made
//    on the device from the same light sample as the CPU's (shaders/common/lights.glsl, the twin
//    of sampleLight) and traced there by the Ray Engine's BVH kernel (GlRayEngine::
//    traceResident); the unoccluded values times F_t (shaders/common/dipole.glsl) summed per
//    element, plus the static share of emitters and the environment;
//  - the MIP-map (shaders/subsurface/sss_mipmap.comp): node means and gradients, one dispatch
//    per wave of nodes whose children are done;
//  - pass 2 (shaders/subsurface/sss_gather.comp): the links, B_i = sum F max(0, E + G offset).
//
// The links, the tree and the elements go up once; a frame uploads its lights (64 bytes each)
// and reads back B (16 bytes per element) for the view (pass 3 stays on the CPU: SssView's
// lookups). Both devices agree within float rounding, but for shadow rays that graze an edge
// (tests/subsurface/sss_gl_test.cpp).
//
// Needs a current OpenGL context (gpu/context.h) on the calling thread.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/gpu/objects.h"
#include "penumbra/raytrace/lights.h"
#include "penumbra/raytrace/ray_engine_gl.h"
#include "penumbra/subsurface/sss.h"

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

namespace penumbra {

// ---- GPU layouts (std430), mirrored in shaders/subsurface/sss_layout.glsl; the lights'
// (GpuLight) are in raytrace/lights.h ----

struct GpuSssElement {  // 64 bytes
  float position[3];
  float eta;  // 0: opaque
  float normal[3];
  float lift;
  float shading_normal[3];
  float pad0;
  float static_irradiance[3];
  float pad1;
};
static_assert(sizeof(GpuSssElement) == 64 && offsetof(GpuSssElement, normal) == 16 &&
              offsetof(GpuSssElement, shading_normal) == 32 &&
              offsetof(GpuSssElement, static_irradiance) == 48);

struct GpuSssNode {  // 32 bytes
  float position[3];
  float area;
  uint32_t child_first;
  uint32_t child_count;
  uint32_t pad0, pad1;
};
static_assert(sizeof(GpuSssNode) == 32 && offsetof(GpuSssNode, child_first) == 16);

struct GpuMat3 {  // 48 bytes: three columns, w unused
  float column[3][4];
};
static_assert(sizeof(GpuMat3) == 48);

struct GpuSssLink {  // 32 bytes
  float factor[3];
  uint32_t node;
  float offset[3];
  float pad;
};
static_assert(sizeof(GpuSssLink) == 32 && offsetof(GpuSssLink, node) == 12 &&
              offsetof(GpuSssLink, offset) == 16);

class GlSss {
 public:
  // Uploads what the passes need from a built solver. Fails (as a value) when a shader does not
  // compile or a buffer exceeds the device's limits.
  static Expected<GlSss> create(const SssSolver& solver);

  // Passes 1 and 2 for this frame's lights; B per element in `scattered` (W m^-2). When `times`
  // is given the passes are timed one by one (each waits for the device: use for measurements).
  Status frame(std::span<const Light> lights, std::vector<glm::vec3>& scattered,
               SssPassTimes* times = nullptr);
  // Pass 1's output of the last frame, E per element (for tests).
  Status downloadIrradiance(std::vector<glm::vec3>& irradiance) const;

 private:
  gl::Program irradiance_rays_, irradiance_sum_, mipmap_, gather_;
  std::optional<GlRayEngine> engine_;
  gl::Buffer elements_, lights_, rays_, hits_, ray_values_, light_tables_;
  std::vector<float> light_tables_data_;  // what light_tables_ holds
  gl::Buffer nodes_, children_, wave_nodes_, moment_inverse_, mean_, gradient_, links_, scattered_;
  std::vector<uint32_t> wave_offset_;  // wave w is wave_nodes[wave_offset[w] .. [w + 1])
  size_t elements_count_ = 0, light_capacity_ = 0;
  uint32_t links_per_element_ = 0;
  bool shadows_ = true;
};

}  // namespace penumbra
