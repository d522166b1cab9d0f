#include "penumbra/methods/illuminance_output.h"

#include "penumbra/core/file_util.h"
#include "penumbra/io/image_io.h"
#include "penumbra/methods/render.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

namespace penumbra {

namespace {

nlohmann::json statsJson(const IlluminanceStats& s) {
  return {{"average_lux", s.average},
          {"minimum_lux", s.minimum},
          {"maximum_lux", s.maximum},
          {"uniformity_u0", s.uniformity}};
}

}  // namespace

bool wantsIlluminance(const RenderOptions& options) {
  // Any of the options: illuminanceRequest then checks that they go together.
  return options.output_quantity != "radiance" || options.work_plane ||
         !options.grid_surface.empty() || options.false_colour || options.lux_max ||
         options.grid_spacing || options.grid_margin || !options.grid_csv.empty();
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
  if (options.lux_max && !(*options.lux_max > 0.0 && *options.lux_max < 1e9)) {
    return inputError("", "--lux-max", fmt::format("{} must be positive", *options.lux_max));
  }
  if (!(options.illuminance_rays >= 1 && options.illuminance_rays <= 65536)) {
    return inputError("", "--illuminance-rays",
                      fmt::format("{} is outside 1..65536", options.illuminance_rays));
  }
  IlluminanceRequest r;
  r.image = lux;
  r.width = width;
  r.height = height;
  r.work_plane = options.work_plane;
  r.surface = options.grid_surface;
  r.spacing = options.grid_spacing.value_or(0.25);
  r.margin = options.grid_margin.value_or(0.0);
  r.grid_rays = options.illuminance_rays;
  r.image_rays = std::max(1, options.illuminance_rays / 4);
  r.seed = options.seed.value_or(0);
  return r;
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
  if (report->grid) {
    const CalculationGrid& g = *report->grid;
    const IlluminanceResult& r = report->grid_result;
    nlohmann::json& out = j[options.work_plane ? "work_plane" : "surface"];
    out = {{"name", g.name},
           {"columns", g.columns},
           {"rows", g.rows},
           {"points", g.points.size()},
           {"spacing_m", g.spacing},
           {"rays_per_point", r.rays},
           {"total", statsJson(r.total_stats)},
           {"direct", statsJson(r.direct_stats)}};
    if (options.work_plane) out["height_m"] = *options.work_plane;
    spdlog::info(
        "{}: {} points, E_avg {:.1f} lx (direct {:.1f}), E_min {:.1f}, E_max {:.1f}, "
        "U0 {:.2f}",
        g.name, g.points.size(), r.total_stats.average, r.direct_stats.average,
        r.total_stats.minimum, r.total_stats.maximum, r.total_stats.uniformity);
    if (!options.grid_csv.empty()) PENUMBRA_TRY(writeIlluminanceCsv(options.grid_csv, g, r));
  }
  if (lux) {
    const IlluminanceResult& r = report->image_result;
    j["image"] = {{"points", r.total.size()},
                  {"rays_per_point", r.rays},
                  {"total", statsJson(r.total_stats)},
                  {"direct", statsJson(r.direct_stats)}};
  }
  j["seconds"] = report->seconds;
  if (stats) (*stats)["illuminance"] = j;
  return {};
}

}  // namespace penumbra
