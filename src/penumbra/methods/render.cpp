// `render` as a library call: the scene's settings applied, the method run, its outputs placed
// together (methods/render.h).
#include "penumbra/methods/render.h"

#include "penumbra/cluster/distributed_render.h"
#include "penumbra/core/check.h"
#include "penumbra/core/file_util.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/timer.h"
#include "penumbra/io/image_io.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/methods/device.h"
#include "penumbra/methods/illuminance_output.h"
#include "penumbra/methods/registry.h"
#include "penumbra/methods/run_context.h"
#include "penumbra/methods/scene_inputs.h"
#include "penumbra/methods/stats_file.h"
#include "penumbra/raytrace/path_tracer.h"
#include "penumbra/raytrace/ray_queries.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <cmath>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>

namespace penumbra {

namespace {}  // namespace

std::string sceneStem(const std::string& scene) {
  const std::filesystem::path p(scene);
  return p.has_extension() ? p.stem().string() : p.filename().string();
}

Status writeMethodImage(const std::string& path, const Image& image,
                        const ToneMapSettings& tonemap) {
  for (size_t i = 0; i < image.pixels.size(); ++i) {
    const glm::vec3& p = image.pixels[i];
    PENUMBRA_CHECK_MSG(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z),
                       "{}: pixel ({}, {}) is ({}, {}, {})", path, i % size_t(image.width),
                       i / size_t(image.width), p.x, p.y, p.z);
  }
  return writeImage(path, image, tonemap);
}

std::string sequenceFrameName(const std::string& path, int frame) {
  const std::filesystem::path p(path);
  std::filesystem::path out = p.parent_path();
  out /= fmt::format("{}_{:04d}{}", p.stem().string(), frame, p.extension().string());
  return out.string();
}

Expected<std::vector<std::string>> checkRenderOutputs(const RenderOptions& options, int frames) {
  std::vector<std::string> outputs = options.outputs;
  if (outputs.empty() && defaultsOutputs()) outputs.push_back(sceneStem(options.scene) + ".png");
  for (const std::string& out : outputs) {
    if (!isSupportedImageExtension(out)) {
      return inputError(out, "",
                        fmt::format("unsupported image format '{}' (use .exr, .hdr, .pfm or .png)",
                                    extensionOf(out)));
    }
    if (frames > 1) {
      const std::string dir = std::filesystem::path(out).parent_path().string();
      if (!dir.empty()) PENUMBRA_TRY(OutputTransaction::current()->createDirectories(dir));
    }
    PENUMBRA_TRY(checkOutputPath(frames > 1 ? sequenceFrameName(out, 0) : out));
  }
  if (!options.stats.empty()) PENUMBRA_TRY(checkOutputPath(options.stats));
  return outputs;
}

namespace {

// The method's run, inside the caller's RunScope and the outputs' transaction.
Status runMethod(const RenderOptions& options, const CommonOptions& common, bool* interrupted) {
  if (options.method == "pathtrace") return renderPathTrace(options, common);
  if (options.method == "whitted" || options.method == "photons") {
    return renderRayTraced(options, common);
  }
  if (options.method == "matrix") return renderMatrix(options, common);
  if (options.method == "progressive" || options.method == "stochastic") {
    return renderLightmapRadiosity(options, common, interrupted);
  }
  if (options.method == "sss") return renderSss(options, common);
  if (options.method == "lpv") return renderLpv(options, common);
  return inputError(
      "", "--method",
      fmt::format("unknown method '{}' (available: {})", options.method, methodNames()));
}

}  // namespace

Expected<RunResult> renderScene(RenderOptions options, const CommonOptions& common,
                                const RunContext& context) {
  // The run sees the scene as its settings and the options make it (methods/scene_inputs.h).
  Expected<RunContext> run = prepareRun(options, context);
  if (!run) return run.error();
  return runInScope(*run, common, [&](bool* interrupted) -> Status {
    PENUMBRA_TRY(checkDistributedMethod(currentCommunicator(), "render", options.method));
    return runMethod(options, common, interrupted);
  });
}

}  // namespace penumbra
