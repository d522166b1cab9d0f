// OpenGL 4.5 core contexts. Headless contexts come from EGL: the device platform first
// (EGL_EXT_platform_device, what a headless NVIDIA or AMD card offers, and Mesa's software
// device), then Mesa's surfaceless platform. Without a GPU this is Mesa llvmpipe, a conformant
// OpenGL 4.5 implementation on the CPU: how every GPU path is executed and tested here.
//
// A context is current on the thread that created it; GPU objects must be used on that thread.
#pragma once

#include "penumbra/core/expected.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace penumbra {

// What a context offers, for `penumbra info --devices` and for sizing work.
struct GlDeviceInfo {
  std::string platform;  // "EGL device 0", "EGL surfaceless"
  std::string vendor, renderer, version;
  int64_t max_ssbo_bytes = 0;
  int max_texture_size = 0;
  int max_compute_invocations = 0;
  int max_compute_group_size[3] = {0, 0, 0};
  int max_compute_group_count[3] = {0, 0, 0};
  int64_t max_compute_shared_bytes = 0;
  bool software = false;  // llvmpipe / softpipe: correctness runs only, never timings
};

class GlContext {
 public:
  // Creates a headless OpenGL 4.5 core context and makes it current on this thread. The error
  // says what each platform answered.
  static Expected<std::unique_ptr<GlContext>> createHeadless();

  ~GlContext();
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  const GlDeviceInfo& info() const { return info_; }
  // Makes the context current on the calling thread (again).
  bool makeCurrent() const;

 private:
  GlContext() = default;
  void* display_ = nullptr;  // EGLDisplay
  void* context_ = nullptr;  // EGLContext
  GlDeviceInfo info_;
};

// Every headless context that can be made, one per EGL device and the surfaceless platform,
// or the reasons none could (for `info --devices`).
struct GlProbe {
  std::vector<GlDeviceInfo> devices;
  std::vector<std::string> failures;
};
GlProbe probeGlDevices();

// Whether tests must fail rather than skip when no context can be made (PENUMBRA_REQUIRE_GL=1).
bool glRequired();

}  // namespace penumbra
