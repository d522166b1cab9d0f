// penumbra-view: the interactive viewer (`penumbra view` runs it). Parses the options and hands
// them to the viewer; everything it shows comes from the library.
#include "penumbra/app/commands.h"
#include "penumbra/core/expected.h"
#include "penumbra/methods/option_spec.h"
#include "penumbra/methods/registry.h"
#include "viewer/viewer.h"

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <string>

namespace {

// A value checked by an option's description, as `render` checks its own (CLI11's Range lets NaN
// through).
CLI::Validator bySpec(const penumbra::OptionSpec& spec) {
  return CLI::Validator(
      [spec](std::string& value) -> std::string {
        const auto parsed = penumbra::parseOption(spec, value, "", "", "--" + spec.name);
        return parsed.ok() ? std::string() : parsed.error().message;
      },
      spec.range ? spec.range->describe() : std::string());
}

}  // namespace

int main(int argc, char** argv) {
  using namespace penumbra;
  viewer::ViewerOptions o;
  // The method's options (spp, seed, elements, iterations, grid, steps) are checked by their
  // descriptions in the library, as `render` checks them (interactive/live_settings.h).
  CLI::App app{
      "penumbra view: a method live on a scene; move the lights, the camera and the "
      "materials and watch the light follow"};
  app.add_option("scene", o.scene, "built-in scene name or file (.json, .obj, .gltf, .glb, .ply)");
  app.add_option("--method", o.method,
                 "pathtrace (default), matrix, progressive, stochastic, sss or lpv");
  app.add_option("--width", o.width,
                 "window width in pixels (default 1120; the image is the window less the 320-pixel "
                 "side panel)")
      ->check(CLI::Range(16, 8192));
  app.add_option("--height", o.height, "window height in pixels (default 640)")
      ->check(CLI::Range(16, 8192));
  app.add_option("--spp", o.spp,
                 "path tracer: samples per pixel to accumulate (default 64); other methods: view "
                 "rays per pixel (default 4)");
  app.add_option("--seed", o.seed, "random seed");
  app.add_option("--elements", o.elements,
                 "radiosity: lightmap texels (progressive, stochastic) or clusters (matrix)");
  app.add_option("--iterations", o.iterations,
                 "radiosity: iteration cap (default 500; stochastic 1000)");
  app.add_option("--device", o.device,
                 "cpu, gpu, or auto (default: the GPU twins of matrix, sss and lpv when the "
                 "window's OpenGL is hardware)")
      ->check(CLI::IsMember({"cpu", "gpu", "auto"}));
  app.add_option("--grid", o.lpv.grid, "lpv: cells along each object's longest side (32)");
  app.add_option("--steps", o.lpv.steps, "lpv: propagation steps (8)");
  std::string tonemap = "reinhard";
  app.add_option("--tonemap", tonemap, "reinhard (automatic key, default) or exposure")
      ->check(CLI::IsMember({"reinhard", "exposure"}));
  app.add_option("--exposure", o.tonemap.exposure_stops, "exposure in stops (default 0)")
      ->check(bySpec(*findOption(renderOptionSpecs(), "exposure")));
  app.add_option("--script", o.script,
                 "scripted input for captures: a JSON light path and camera path (docs/viewer.md)");
  app.add_option("--screenshot", o.screenshot,
                 "capture: write the window to this .png after --frames frames and exit");
  app.add_option("--frames", o.frames, "capture: frames to run (default 1)")
      ->check(CLI::Range(1, 100000));
  app.add_flag("--sequence", o.sequence, "capture: write every frame (name_0000.png, ...)");
  app.add_flag("--hide-ui", o.hide_ui, "show the image alone, without panels or light markers");
  app.add_flag("--live", o.live,
               "capture: each frame works within --budget-ms as the window does, instead of "
               "finishing its work (measures the frame rate)");
  app.add_option("--stats", o.stats, "capture: per-frame times and the frame rate (JSON)");
  double budget_ms = 1e3 * o.budget;
  const OptionSpec budget_spec{
      .name = "budget-ms", .kind = OptionKind::kReal, .range = OptionRange{1.0, 10000.0}};
  app.add_option("--budget-ms", budget_ms, "solver work per frame in milliseconds (default 16.7)")
      ->check(bySpec(budget_spec));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    return reportError(inputError("", "", fmt::format("{} (see penumbra view --help)", e.what())));
  }
  o.budget = budget_ms * 1e-3;
  o.tonemap.op = tonemap == "exposure" ? ToneMapOperator::kExposure : ToneMapOperator::kReinhard;
  if ((o.frames > 0 || o.sequence || o.live || !o.stats.empty()) && o.screenshot.empty()) {
    return reportError(inputError("", "--frames", "needs --screenshot"));
  }
  if (!o.script.empty() && o.screenshot.empty()) {
    return reportError(inputError("", "--script", "needs --screenshot (scripted captures)"));
  }
  const Status s = viewer::runViewer(o);
  if (!s.ok()) return reportError(s.error());
  return 0;
}
