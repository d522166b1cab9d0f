// `--device cpu|gpu|auto` (design doc sec. 3).
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/gpu/context.h"

#include <memory>
#include <string>

namespace penumbra {

enum class Device { kCpu, kGpu };

struct DeviceChoice {
  Device device = Device::kCpu;
  std::unique_ptr<GlContext> context;  // current on this thread when device is kGpu
  std::string name() const { return device == Device::kGpu ? "gpu" : "cpu"; }
};

// cpu: the CPU. gpu: an OpenGL 4.5 context or an error saying why none could be made.
// auto: the GPU when a hardware context can be made, else the CPU, saying which it took and
// why. A software rasteriser (Mesa llvmpipe) is taken only when asked for with `gpu`: it runs
// every GPU path correctly but far slower than the CPU back ends.
Expected<DeviceChoice> chooseDevice(const std::string& requested);

}  // namespace penumbra
