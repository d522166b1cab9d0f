#include "penumbra/render/calculation_report.h"

#include "penumbra/core/file_util.h"
#include "penumbra/io/image_io.h"
#include "penumbra/render/plot.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>

namespace penumbra {

namespace {

std::string fileStem(const std::string& name) {
  std::string stem;
  for (char c : name) {
    stem += (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_') ? c : '_';
  }
  return stem.empty() ? std::string("object") : stem;
}

std::string luxText(double v) {
  return v >= 99.95 ? fmt::format("{:.0f}", v) : fmt::format("{:.1f}", v);
}

Status writeText(const std::string& path, const std::string& text) {
  return writeAtomically(path, [&](const std::string& tmp) -> Status {
    std::FILE* f = std::fopen(tmp.c_str(), "w");
    if (!f) return runtimeError(path, "cannot write the report");
    const bool ok = std::fwrite(text.data(), 1, text.size(), f) == text.size();
    if (std::fclose(f) != 0 || !ok) return runtimeError(path, "cannot write the report");
    return {};
  });
}

}  // namespace

nlohmann::json illuminanceStatsJson(const IlluminanceStats& s) {
  return {{"average_lux", s.average},
          {"minimum_lux", s.minimum},
          {"maximum_lux", s.maximum},
          {"uniformity_u0", s.uniformity},
          {"uniformity_u1", s.uniformity_u1}};
}

nlohmann::json glareJson(const GlareResult& g) {
  nlohmann::json sources = nlohmann::json::array();
  for (const GlareSource& s : g.sources) {
    sources.push_back({{"name", s.name},
                       {"luminance_cd_m2", s.term.luminance},
                       {"solid_angle_sr", s.term.solid_angle},
                       {"position_index", s.term.position_index},
                       {"share", g.sum > 0.0 ? s.term.term / g.sum : 0.0}});
  }
  return {{"ugr", std::isnan(g.ugr) ? nlohmann::json() : nlohmann::json(g.ugr)},
          {"background_luminance_cd_m2", g.background_luminance},
          {"sources", sources}};
}

nlohmann::json calculationObjectJson(const CalculationGrid& g, const IlluminanceResult& r) {
  nlohmann::json j = {{"name", g.name},
                      {"type", g.type},
                      {"measure", g.measure == Measure::kCylindrical ? "cylindrical" : "planar"},
                      {"columns", g.columns},
                      {"rows", g.rows},
                      {"points", g.points.size()},
                      {"spacing_m", g.spacing},
                      {"rays_per_point", r.rays},
                      {"total", illuminanceStatsJson(r.total_stats)},
                      {"direct", illuminanceStatsJson(r.direct_stats)}};
  if (!r.glare.empty()) {
    // UGR per observer, and the worst, as EN 12464-1 limits it.
    nlohmann::json observers = nlohmann::json::array();
    double worst = std::nan("");
    for (size_t i = 0; i < r.glare.size(); ++i) {
      nlohmann::json o = glareJson(r.glare[i]);
      o["position"] = {g.points[i].x, g.points[i].y, g.points[i].z};
      o["view"] = {g.normals[i].x, g.normals[i].y, g.normals[i].z};
      o["vertical_lux"] = r.total[i];
      if (i < g.labels.size() && !g.labels[i].empty()) o["name"] = g.labels[i];
      observers.push_back(o);
      if (!std::isnan(r.glare[i].ugr) && !(r.glare[i].ugr <= worst)) worst = r.glare[i].ugr;
    }
    j["observers"] = observers;
    j["ugr_max"] = std::isnan(worst) ? nlohmann::json() : nlohmann::json(worst);
  }
  if (!r.sky.empty() && r.horizontal_lux > 0.0) {
    // Daylight factors (CIE 171:2006 sec. 5.9-5.14): the lux over the unobstructed sky's
    // horizontal illuminance, in percent; SC and ERC averaged like the lux.
    std::vector<double> df(r.total.size()), sc(r.sky.size()), erc(r.external.size());
    for (size_t i = 0; i < df.size(); ++i) {
      df[i] = 100.0 * r.total[i] / r.horizontal_lux;
      sc[i] = 100.0 * r.sky[i] / r.horizontal_lux;
      erc[i] = 100.0 * r.external[i] / r.horizontal_lux;
    }
    const IlluminanceStats d = illuminanceStats(df, g.areas);
    j["daylight"] = {
        {"horizontal_illuminance_lux", r.horizontal_lux},
        {"daylight_factor_pct",
         {{"average", d.average}, {"minimum", d.minimum}, {"maximum", d.maximum}}},
        {"sky_component_pct", illuminanceStats(sc, g.areas).average},
        {"externally_reflected_component_pct", illuminanceStats(erc, g.areas).average}};
  }
  return j;
}

Image planViewImage(const CalculationGrid& g, const IlluminanceResult& r, double max_lux) {
  if (!(max_lux > 0.0)) max_lux = niceCeiling(std::max(r.total_stats.maximum, 1e-9));
  const int cols = std::max(g.columns, 1), rows = std::max(g.rows, 1);
  const int cell = std::clamp(1000 / std::max(cols, rows), 6, 64);
  const int top = 44, left = 10, legend = 40 + Canvas::textWidth("00000 lx", 1);
  const int width = left + cols * cell + 10 + legend, height = top + rows * cell + 10;
  Canvas canvas(width, std::max(height, 160), glm::vec3(1.0f));
  const glm::vec3 ink(0.0f);
  canvas.text(left, 8, g.name, ink, 2);
  canvas.text(left, 28,
              fmt::format("E_avg {:.1f} lx  E_min {:.1f}  E_max {:.1f}  U0 {:.2f}  U1 {:.2f}",
                          r.total_stats.average, r.total_stats.minimum, r.total_stats.maximum,
                          r.total_stats.uniformity, r.total_stats.uniformity_u1),
              ink, 1);
  const bool print = cell >= Canvas::textWidth("0000", 1) + 4;
  for (int y = 0; y < rows; ++y) {
    for (int x = 0; x < cols; ++x) {
      const size_t i = size_t(y) * size_t(cols) + size_t(x);
      if (i >= r.total.size()) continue;
      const int x0 = left + x * cell, y0 = top + y * cell;
      canvas.fillRect(x0, y0, x0 + cell, y0 + cell, falseColour(float(r.total[i] / max_lux)));
      if (print) {
        const std::string t = luxText(r.total[i]);
        const int tw = Canvas::textWidth(t, 1);
        canvas.text(x0 + (cell - tw) / 2, y0 + cell / 2 - 4, t, ink, 1);
      }
    }
  }
  // Cell borders when the cells are large enough to read.
  if (cell >= 12) {
    for (int x = 0; x <= cols; ++x) {
      canvas.fillRect(left + x * cell, top, left + x * cell + 1, top + rows * cell,
                      glm::vec3(0.3f));
    }
    for (int y = 0; y <= rows; ++y) {
      canvas.fillRect(left, top + y * cell, left + cols * cell + 1, top + y * cell + 1,
                      glm::vec3(0.3f));
    }
  }
  const int bar_x = left + cols * cell + 14, bar_w = 14, bar_top = top,
            bar_bottom = std::max(top + rows * cell, top + 100);
  for (int y = bar_top; y < bar_bottom; ++y) {
    const float t = float(bar_bottom - 1 - y) / float(std::max(1, bar_bottom - bar_top - 1));
    canvas.fillRect(bar_x, y, bar_x + bar_w, y + 1, falseColour(t));
  }
  for (int k = 0; k <= 4; ++k) {
    const int y = bar_bottom - 1 - int(std::lround(double(bar_bottom - bar_top - 1) * k / 4.0));
    canvas.fillRect(bar_x + bar_w, y, bar_x + bar_w + 4, y + 1, ink);
    canvas.text(bar_x + bar_w + 6, y - 3, fmt::format("{:g} lx", max_lux * k / 4.0), ink, 1);
  }
  return canvas.image();
}

Status writeCalculationReports(const std::string& dir, const IlluminanceReport& report) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return runtimeError(dir, fmt::format("cannot make the report folder: {}", ec.message()));
  std::set<std::string> used;
  for (size_t k = 0; k < report.grids.size(); ++k) {
    const CalculationGrid& g = report.grids[k];
    const IlluminanceResult& r = report.grid_results[k];
    std::string stem = fileStem(g.name);
    for (int n = 2; used.count(stem); ++n) stem = fmt::format("{}-{}", fileStem(g.name), n);
    used.insert(stem);
    const std::string base = (std::filesystem::path(dir) / stem).string();
    // The CSV: a row per point.
    std::string csv =
        fmt::format("# {}: {} x {} points, {} rays each, {} illuminance\n", g.name, g.columns,
                    g.rows, r.rays, g.measure == Measure::kCylindrical ? "cylindrical" : "planar");
    const bool daylight = !r.sky.empty() && r.horizontal_lux > 0.0;
    const bool glare = !r.glare.empty();
    csv += "name,x_m,y_m,z_m,nx,ny,nz,direct_lux,total_lux";
    csv += daylight ? ",sc_pct,erc_pct,df_pct" : "";
    csv += glare ? ",ugr,background_cd_m2\n" : "\n";
    nlohmann::json points = nlohmann::json::array();
    for (size_t i = 0; i < g.points.size(); ++i) {
      const glm::dvec3 &p = g.points[i], &n = g.normals[i];
      const std::string label = i < g.labels.size() ? g.labels[i] : std::string();
      csv += fmt::format("{},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.3f},{:.3f}", label, p.x,
                         p.y, p.z, n.x, n.y, n.z, r.direct[i], r.total[i]);
      if (daylight) {
        csv += fmt::format(",{:.4f},{:.4f},{:.4f}", 100.0 * r.sky[i] / r.horizontal_lux,
                           100.0 * r.external[i] / r.horizontal_lux,
                           100.0 * r.total[i] / r.horizontal_lux);
      }
      if (glare) {
        const GlareResult& gr = r.glare[i];
        csv += std::isnan(gr.ugr) ? std::string(",") : fmt::format(",{:.2f}", gr.ugr);
        csv += fmt::format(",{:.4f}", gr.background_luminance);
      }
      csv += "\n";
      nlohmann::json pj = {{"position", {p.x, p.y, p.z}},
                           {"normal", {n.x, n.y, n.z}},
                           {"direct_lux", r.direct[i]},
                           {"total_lux", r.total[i]}};
      if (!label.empty()) pj["name"] = label;
      if (daylight) {
        pj["sky_component_pct"] = 100.0 * r.sky[i] / r.horizontal_lux;
        pj["externally_reflected_component_pct"] = 100.0 * r.external[i] / r.horizontal_lux;
        pj["daylight_factor_pct"] = 100.0 * r.total[i] / r.horizontal_lux;
      }
      points.push_back(pj);
    }
    PENUMBRA_TRY(writeText(base + ".csv", csv));
    nlohmann::json j = calculationObjectJson(g, r);
    j["point_values"] = points;
    PENUMBRA_TRY(writeText(base + ".json", j.dump(2) + "\n"));
    if (g.rows > 1 && g.columns > 1) {
      ToneMapSettings none;
      none.op = ToneMapOperator::kNone;
      PENUMBRA_TRY(writeImage(base + ".png", planViewImage(g, r), none));
    }
  }
  return {};
}

}  // namespace penumbra
