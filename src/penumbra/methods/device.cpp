#include "penumbra/methods/device.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

namespace penumbra {

Expected<DeviceChoice> chooseDevice(const std::string& requested) {
  DeviceChoice choice;
  if (requested == "cpu") return choice;
  if (requested != "gpu" && requested != "auto") {
    return inputError("", "", fmt::format("--device '{}': use cpu, gpu or auto", requested));
  }
  Expected<std::unique_ptr<GlContext>> ctx = GlContext::createHeadless();
  if (!ctx) {
    if (requested == "gpu") {
      return inputError("", "", "--device gpu: " + ctx.error().describe());
    }
    spdlog::info("device: cpu (no GPU: {})", ctx.error().describe());
    return choice;
  }
  const GlDeviceInfo& info = (*ctx)->info();
  if (requested == "auto" && info.software) {
    spdlog::info("device: cpu ({} is a software renderer; --device gpu uses it anyway)",
                 info.renderer);
    return choice;
  }
  spdlog::info("device: gpu ({}, {}){}", info.renderer, info.version,
               info.software ? "; a software renderer: correctness runs, not timings" : "");
  choice.device = Device::kGpu;
  choice.context = std::move(*ctx);
  return choice;
}

}  // namespace penumbra
