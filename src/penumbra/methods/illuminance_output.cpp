#include "penumbra/methods/illuminance_output.h"

#include "penumbra/core/file_util.h"
#include "penumbra/io/image_io.h"
#include "penumbra/methods/render.h"
#include "penumbra/render/calculation_report.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <filesystem>

namespace penumbra {

bool wantsIlluminance(const RenderOptions& options) {
  // Any of the options: illuminanceRequest then checks that they go together.
  return options.output_quantity != "radiance" || options.work_plane ||
         !options.grid_surface.empty() || options.false_colour || options.lux_max ||
         options.grid_spacing || options.grid_margin || !options.grid_csv.empty() ||
         !options.calc_files.empty() || !options.points_files.empty() ||
         !options.report_dir.empty();
}

Expected<IlluminanceRequest> illuminanceRequest(const RenderOptions& options, int width,
                                                int height) {
  if (options.output_quantity != "radiance" && options.output_quantity != "illuminance") {
    return inputError("", "--output-quantity",
                      fmt::format("'{}' is not radiance or illuminance", options.output_quantity));
  }
  const bool lux = options.output_quantity == "illuminance";
  if (!lux && (options.false_colour || options.lux_max)) {
    return inputError("", options.false_colour ? "--false-colour" : "--lux-max",
                      "applies to --output-quantity illuminance only");
  }
  const bool surface = !options.grid_surface.empty();
  if (options.work_plane && surface) {
    return inputError("", "--grid-surface", "one grid at a time: not with --work-plane");
  }
  if (!options.work_plane && !surface && (options.grid_spacing || !options.grid_csv.empty())) {
    return inputError("", options.grid_spacing ? "--grid-spacing" : "--grid-csv",
                      "applies with --work-plane or --grid-surface only");
  }
  if (!options.work_plane && options.grid_margin) {
    return inputError("", "--grid-margin", "applies with --work-plane only");
  }
  if (!options.grid_csv.empty()) PENUMBRA_TRY(checkOutputPath(options.grid_csv));
  for (const std::string& f : options.calc_files) PENUMBRA_TRY(checkInputFile(f));
  for (const std::string& f : options.points_files) PENUMBRA_TRY(checkInputFile(f));
  if (!options.report_dir.empty()) {
    std::error_code ec;
    if (std::filesystem::exists(options.report_dir, ec) &&
        !std::filesystem::is_directory(options.report_dir, ec)) {
      return inputError("", "--report",
                        fmt::format("'{}' exists and is not a folder", options.report_dir));
    }
  }
  if (options.lux_max && !(*options.lux_max > 0.0 && *options.lux_max < 1e9)) {
    return inputError("", "--lux-max", fmt::format("{} must be positive", *options.lux_max));
  }
  if (options.illuminance_rays &&
      !(*options.illuminance_rays >= 1 && *options.illuminance_rays <= 65536)) {
    return inputError("", "--illuminance-rays",
                      fmt::format("{} is outside 1..65536", *options.illuminance_rays));
  }
  IlluminanceRequest r;
  r.image = lux;
  r.width = width;
  r.height = height;
  r.work_plane = options.work_plane;
  r.surface = options.grid_surface;
  r.spacing = options.grid_spacing.value_or(0.25);
  r.margin = options.grid_margin.value_or(0.0);
  r.calc_files = options.calc_files;
  r.points_files = options.points_files;
  r.grid_rays = options.illuminance_rays.value_or(0);  // 0: autoIlluminanceRays
  r.image_rays = options.illuminance_rays ? std::max(1, *options.illuminance_rays / 4) : 64;
  r.seed = options.seed.value_or(0);
  return r;
}

Status prepareIlluminance(std::optional<IlluminanceRequest>& lux, const RenderOptions& options,
                          const Scene& scene, int width, int height) {
  if (!lux && !scene.calculation.empty()) {
    Expected<IlluminanceRequest> r = illuminanceRequest(options, width, height);
    if (!r) return r.error();
    lux = *r;
  }
  if (lux) PENUMBRA_TRY(checkIlluminanceRequest(scene, *lux));
  return {};
}

Image renderedValues(const RenderOptions& options, const Image& radiance,
                     const IlluminanceReport* report) {
  if (!report || options.output_quantity != "illuminance") return radiance;
  Image values(radiance.width, radiance.height);
  for (size_t i = 0; i < values.pixels.size(); ++i) {
    values.pixels[i] = glm::vec3(float(std::max(0.0, report->image_lux[i])));
  }
  return values;
}

Status writeRenderOutputs(const RenderOptions& options, const std::vector<std::string>& outputs,
                          const Image& radiance, const IlluminanceReport* report,
                          nlohmann::json* stats, const std::string& frame_name) {
  const bool lux = report && options.output_quantity == "illuminance";
  for (const std::string& out : outputs) {
    const std::string path = frame_name.empty() ? out : frame_name;  // a sequence's frame
    if (!lux) {
      PENUMBRA_TRY(writeMethodImage(path, radiance, options.tonemap));
      continue;
    }
    const int w = radiance.width, h = radiance.height;
    if (extensionOf(path) == ".png" && options.false_colour) {
      const Image picture = falseColourImage(report->image_lux, w, h, options.lux_max.value_or(0));
      ToneMapSettings none;
      none.op = ToneMapOperator::kNone;
      PENUMBRA_TRY(writeMethodImage(path, picture, none));
    } else {
      PENUMBRA_TRY(
          writeMethodImage(path, renderedValues(options, radiance, report), options.tonemap));
    }
  }
  if (!report) return {};
  nlohmann::json j;
  nlohmann::json objects = nlohmann::json::array();
  const bool command_line_grid = options.work_plane || !options.grid_surface.empty();
  for (size_t k = 0; k < report->grids.size(); ++k) {
    const CalculationGrid& g = report->grids[k];
    const IlluminanceResult& r = report->grid_results[k];
    nlohmann::json out = calculationObjectJson(g, r);
    if (k == 0 && command_line_grid) {
      // The command line's grid also under its own key, and in --grid-csv.
      if (options.work_plane) out["height_m"] = *options.work_plane;
      j[options.work_plane ? "work_plane" : "surface"] = out;
      if (!options.grid_csv.empty()) PENUMBRA_TRY(writeIlluminanceCsv(options.grid_csv, g, r));
    }
    for (size_t i = 0; i < r.glare.size(); ++i) {
      const GlareResult& gr = r.glare[i];
      const std::string who = i < g.labels.size() && !g.labels[i].empty()
                                  ? g.labels[i]
                                  : fmt::format("observer {}", i + 1);
      spdlog::info(
          "{}: {}: UGR {}, background {:.2f} cd/m2, {} sources in view", g.name, who,
          std::isnan(gr.ugr) ? std::string("none (nothing glares)") : fmt::format("{:.1f}", gr.ugr),
          gr.background_luminance, gr.sources.size());
    }
    spdlog::info(
        "{}: {} points, E_avg {:.1f} lx (direct {:.1f}), E_min {:.1f}, E_max {:.1f}, "
        "U0 {:.2f}, U1 {:.2f}",
        g.name, g.points.size(), r.total_stats.average, r.direct_stats.average,
        r.total_stats.minimum, r.total_stats.maximum, r.total_stats.uniformity,
        r.total_stats.uniformity_u1);
    objects.push_back(out);
  }
  if (!report->grids.empty()) j["objects"] = objects;
  if (!options.report_dir.empty()) {
    PENUMBRA_TRY(writeCalculationReports(options.report_dir, *report));
  }
  if (lux) {
    const IlluminanceResult& r = report->image_result;
    j["image"] = {{"points", r.total.size()},
                  {"rays_per_point", r.rays},
                  {"total", illuminanceStatsJson(r.total_stats)},
                  {"direct", illuminanceStatsJson(r.direct_stats)}};
  }
  j["seconds"] = report->seconds;
  if (stats) (*stats)["illuminance"] = j;
  return {};
}

}  // namespace penumbra
