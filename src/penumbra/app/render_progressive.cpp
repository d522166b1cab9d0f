// `penumbra render --method progressive`: progressive refinement radiosity in a lightmap atlas
// (Wallner, sec. 2-3) on the CPU, viewed from the camera through the lightmap with bilinear
// filtering, as a lightmapped scene is displayed.
#include "penumbra/app/commands.h"
#include "penumbra/app/device.h"
#include "penumbra/app/stats_file.h"
#include "penumbra/core/file_util.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/timer.h"
#include "penumbra/io/image_io.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/radiosity/progressive.h"
#include "penumbra/render/lightmap_view.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <glm/geometric.hpp>

#include <cmath>
#include <filesystem>

namespace penumbra {

Status renderProgressive(const RenderOptions& options, const CommonOptions& common) {
  std::vector<std::string> outputs = options.outputs;
  if (outputs.empty()) {
    const std::filesystem::path p(options.scene);
    outputs.push_back((p.has_extension() ? p.stem().string() : options.scene) + ".png");
  }
  for (const std::string& out : outputs) {
    if (!isSupportedImageExtension(out)) {
      return inputError(out, "",
                        fmt::format("unsupported image format '{}' (use .exr, .hdr, .pfm or .png)",
                                    extensionOf(out)));
    }
    PENUMBRA_TRY(checkOutputPath(out));
  }
  if (!options.stats.empty()) PENUMBRA_TRY(checkOutputPath(options.stats));
  if (options.max_depth) return inputError("", "--max-depth", "applies to --method pathtrace only");
  if (options.solver) return inputError("", "--solver", "applies to --method matrix only");
  if (options.relight_frames > 0) {
    return inputError("", "--relight-frames", "applies to --method matrix only");
  }
  if (options.device == "gpu" || options.device == "hybrid") {
    return inputError(
        "", "--device",
        fmt::format("'{}': progressive radiosity runs on the CPU in this version", options.device));
  }
  const double tolerance = options.tolerance.value_or(1e-3);
  if (tolerance > 1.0) return inputError("", "--tolerance", "is a fraction, at most 1");
  const int width = options.width.value_or(512), height = options.height.value_or(512);
  const int spp = options.spp.value_or(4);
  if (width < 1 || width > (1 << 16) || height < 1 || height > (1 << 16)) {
    return inputError("", "--width/--height", "must be in [1, 65536]");
  }
  if (spp < 1 || spp > 4096) return inputError("", "--spp", "must be in [1, 4096]");
  PENUMBRA_TRY(checkMemory(uint64_t(width) * uint64_t(height) * 40,
                           fmt::format("a {}x{} image", width, height)));

  const Timer total_timer;
  Expected<Scene> scene = loadScene(options.scene);
  if (!scene) return scene.error();
  for (const std::string& w : scene->warnings) spdlog::warn("{}", w);
  if (!scene->lights.empty()) {
    spdlog::warn(
        "{}: {} point/spot/directional light(s) ignored: progressive radiosity is lit by "
        "emissive surfaces only in this version",
        scene->source, scene->lights.size());
  }

  // The texel density that gives about --elements occupied texels: texels per metre, so that
  // density^2 * total area = elements.
  const FlatTriangles flat = flattenScene(*scene);
  double total_area = 0.0;
  for (const glm::uvec3& t : flat.triangles) {
    total_area += 0.5 * double(glm::length(glm::cross(flat.positions[t.y] - flat.positions[t.x],
                                                      flat.positions[t.z] - flat.positions[t.x])));
  }
  if (!(total_area > 0.0)) return inputError(scene->source, "", "the scene has no surface area");
  ProgressiveOptions po;
  po.atlas.texel_density = std::sqrt(double(options.elements) / total_area);
  po.max_iterations = options.iterations;
  po.convergence = tolerance;
  // Per element: radiosity, residual, reflectance, emission, position, area, ids (~150 bytes),
  // plus the atlas (~32 bytes per texel, about twice the elements with gutters).
  PENUMBRA_TRY(checkMemory(uint64_t(options.elements) * 220,
                           fmt::format("progressive radiosity with {} texels", options.elements)));

  const Timer build_timer;
  Expected<ProgressiveRadiosity> built = ProgressiveRadiosity::build(*scene, po);
  if (!built) return built.error();
  ProgressiveRadiosity& pr = *built;
  const double build_seconds = build_timer.seconds();
  spdlog::info("{}: {} lightmap texels in a {}x{} atlas ({:.1f} texels/m)", scene->source,
               pr.elementCount(), pr.atlas().width, pr.atlas().height, pr.atlas().texel_density);

  // Progress: the fraction of the emitted power shot so far, on a log scale down to the
  // tolerance (the iteration count is not known in advance).
  Progress progress("shooting", 1000, !common.quiet && Progress::stderrIsTerminal());
  const double log_goal = std::log(std::max(tolerance, 1e-12));
  nlohmann::json history = nlohmann::json::array();
  const ProgressiveStats st = pr.solve([&](const ProgressiveIteration& it) {
    history.push_back(it.unshot_fraction);
    const double f = it.unshot_fraction > 0.0 ? std::log(it.unshot_fraction) / log_goal : 1.0;
    progress.reach(uint64_t(std::clamp(f, 0.0, 1.0) * 1000.0));
  });
  progress.finish();
  if (!st.converged) {
    spdlog::warn(
        "not converged: {:.3g} of the emitted power unshot after {} iterations "
        "(tolerance {:.3g})",
        st.unshot_fraction, st.iterations, tolerance);
  }

  const Timer view_timer;
  const Camera camera = scene->camera ? *scene->camera : defaultCamera(*scene);
  LightmapViewSettings view;
  view.width = width;
  view.height = height;
  view.spp = spp;
  view.seed = options.seed.value_or(0);
  const Image lightmap = pr.radianceImage(false);
  const Image image =
      renderLightmapView(flat.positions, flat.triangles, pr.atlas(), lightmap, camera, view);
  const double view_seconds = view_timer.seconds();
  for (const std::string& out : outputs) PENUMBRA_TRY(writeImage(out, image, options.tonemap));
  spdlog::info("{} iterations, {:.3g} of the emitted power unshot, {:.2f} s; wrote {}",
               st.iterations, st.unshot_fraction, st.seconds, fmt::join(outputs, ", "));

  if (!options.stats.empty()) {
    const EnergyBalance& b = pr.balance();
    nlohmann::json j = {{"method", "progressive"},
                        {"device", "cpu"},
                        {"scene", scene->source},
                        {"seconds", total_timer.seconds()},
                        {"build_seconds", build_seconds},
                        {"solve_seconds", st.seconds},
                        {"view_seconds", view_seconds},
                        {"elements", pr.elementCount()},
                        {"atlas_width", pr.atlas().width},
                        {"atlas_height", pr.atlas().height},
                        {"texel_density", pr.atlas().texel_density},
                        {"iterations", st.iterations},
                        {"unshot_fraction", st.unshot_fraction},
                        {"converged", st.converged},
                        {"tolerance", tolerance},
                        {"history", history},
                        {"rays", st.rays},
                        {"emitted_w", {b.emitted.x, b.emitted.y, b.emitted.z}},
                        {"absorbed_w", {b.absorbed.x, b.absorbed.y, b.absorbed.z}},
                        {"unshot_w", {b.unshot.x, b.unshot.y, b.unshot.z}},
                        {"escaped_w", {b.escaped.x, b.escaped.y, b.escaped.z}},
                        {"threads", threadCount()},
                        {"width", width},
                        {"height", height},
                        {"spp", spp}};
    PENUMBRA_TRY(writeStatsFile(options.stats, j));
  }
  return {};
}

}  // namespace penumbra
