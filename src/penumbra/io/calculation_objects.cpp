#include "penumbra/io/calculation_objects.h"

#include "penumbra/core/file_util.h"
#include "penumbra/io/json_guard.h"
#include "penumbra/io/json_reader.h"

#include <fmt/format.h>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <numbers>
#include <sstream>

namespace penumbra {

namespace {

using nlohmann::json;

// A points object's list: [{"position": [...], "normal": [...], "name": "..."}, ...]; a glare
// object's has "view" for "normal", required and not within kMaxViewElevation of vertical.
Status readPointList(const JsonReader& r, const json& list, const std::string& place,
                     CalculationGrid& g, const char* normal_key = "normal") {
  const bool glare = std::string(normal_key) == "view";
  if (!list.is_array()) {
    return r.error(place, fmt::format("must be an array of points, not {}", jsonTypeName(list)));
  }
  if (list.size() > kMaxCalculationPoints) {
    return r.error(place, fmt::format("{} points (at most 4 million)", list.size()));
  }
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string at = fmt::format("{}[{}]", place, i);
    const json& p = list[i];
    if (!p.is_object()) {
      return r.error(at, fmt::format("must be an object, not {}", jsonTypeName(p)));
    }
    PENUMBRA_TRY(r.keys(p, at, {"position", normal_key, "name"}));
    if (!p.contains("position")) return r.error(keyOf(at, "position"), "missing");
    Expected<glm::dvec3> x = r.vec3(p.at("position"), keyOf(at, "position"));
    if (!x) return x.error();
    glm::dvec3 n(0.0, 1.0, 0.0);
    if (glare && !p.contains(normal_key)) return r.error(keyOf(at, normal_key), "missing");
    if (p.contains(normal_key)) {
      Expected<glm::dvec3> d = r.direction(p.at(normal_key), keyOf(at, normal_key));
      if (!d) return d.error();
      n = *d;
    }
    if (glare && std::abs(n.y) > std::sin(kMaxViewElevation * std::numbers::pi / 180.0)) {
      return r.error(keyOf(at, normal_key),
                     fmt::format("a line of sight within {:g} degrees of the vertical has no "
                                 "horizon for Guth's position index",
                                 90.0 - kMaxViewElevation));
    }
    std::string label;
    if (p.contains("name")) {
      Expected<std::string> s = r.string(p.at("name"), keyOf(at, "name"));
      if (!s) return s.error();
      label = *s;
    }
    g.points.push_back(*x);
    g.normals.push_back(n);
    g.labels.push_back(label);
  }
  return {};
}

// CSV rows x,y,z[,nx,ny,nz[,name]].
Expected<CalculationGrid> readPointsCsv(const std::string& path, const std::string& text) {
  CalculationGrid g;
  g.type = "points";
  std::istringstream in(text);
  std::string line;
  int line_no = 0;
  bool header_allowed = true;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    std::vector<std::string> cells;
    std::stringstream row(line);
    std::string cell;
    while (std::getline(row, cell, ',')) {
      const size_t a = cell.find_first_not_of(" \t"), b = cell.find_last_not_of(" \t");
      cells.push_back(a == std::string::npos ? std::string() : cell.substr(a, b - a + 1));
    }
    const std::string at = fmt::format("line {}", line_no);
    double v[6] = {0, 0, 0, 0, 1, 0};
    const size_t numeric = cells.size() >= 6 ? 6 : 3;
    if (cells.size() != 3 && cells.size() != 6 && cells.size() != 7) {
      return inputError(path, at,
                        fmt::format("{} values: a point is x,y,z or x,y,z,nx,ny,nz with an "
                                    "optional name",
                                    cells.size()));
    }
    bool ok = true;
    for (size_t k = 0; k < numeric && ok; ++k) {
      char* end = nullptr;
      v[k] = std::strtod(cells[k].c_str(), &end);
      ok = !cells[k].empty() && end && *end == '\0' && std::isfinite(v[k]);
    }
    if (!ok) {
      if (header_allowed) {  // a header line such as "x,y,z,nx,ny,nz,name"
        header_allowed = false;
        continue;
      }
      return inputError(path, at, "a value is not a finite number");
    }
    header_allowed = false;
    for (int k = 0; k < 3; ++k) {
      if (std::fabs(v[k]) > 1e9) return inputError(path, at, fmt::format("{} is over 1e9 m", v[k]));
    }
    const glm::dvec3 n(v[3], v[4], v[5]);
    const double len = glm::length(n);
    if (!(len > 1e-12)) return inputError(path, at, "the normal is a zero vector");
    if (g.points.size() >= kMaxCalculationPoints) {
      return inputError(path, at, "more than 4 million points");
    }
    g.points.emplace_back(v[0], v[1], v[2]);
    g.normals.push_back(n / len);
    g.labels.push_back(cells.size() == 7 ? cells[6] : std::string());
  }
  if (g.points.empty()) return inputError(path, "", "no calculation points");
  return g;
}

void finishList(CalculationGrid& g) {
  g.columns = int(g.points.size());
  g.rows = 1;
  bool named = false;
  for (const std::string& l : g.labels) named = named || !l.empty();
  if (!named) g.labels.clear();
}

// A "grid" object: origin, u, v, the normal (for cylindrical illuminance: the axis).
Expected<CalculationGrid> gridObject(const JsonReader& r, const json& o, const std::string& at,
                                     const std::string& name, Measure measure, double spacing,
                                     double margin) {
  PENUMBRA_TRY(r.keys(
      o, at, {"type", "name", "measure", "origin", "u", "v", "normal", "spacing", "margin"}));
  glm::dvec3 corner[3];
  const char* keys[3] = {"origin", "u", "v"};
  for (int k = 0; k < 3; ++k) {
    if (!o.contains(keys[k])) return r.error(keyOf(at, keys[k]), "missing");
    Expected<glm::dvec3> x = r.vec3(o.at(keys[k]), keyOf(at, keys[k]));
    if (!x) return x.error();
    corner[k] = *x;
  }
  glm::dvec3 n = glm::cross(corner[1], corner[2]);
  if (measure == Measure::kCylindrical) n = glm::dvec3(0.0, 1.0, 0.0);
  if (o.contains("normal")) {
    Expected<glm::dvec3> d = r.direction(o.at("normal"), keyOf(at, "normal"));
    if (!d) return d.error();
    n = *d;
  }
  const double len = glm::length(n);
  if (!(len > 0.0)) return r.error(keyOf(at, "u"), "u and v must span a rectangle");
  if (measure != Measure::kCylindrical) {
    return planeGrid(name, corner[0], corner[1], corner[2], n / len, spacing, margin, r.file, at);
  }
  // The axis need not lie square to the plane (a vertical axis over an inclined plane).
  Expected<CalculationGrid> g = planeGrid(name, corner[0], corner[1], corner[2], glm::dvec3(0.0),
                                          spacing, margin, r.file, at);
  if (g) {
    for (glm::dvec3& axis : g->normals) axis = n / len;
  }
  return g;
}

}  // namespace

Expected<CalculationGrid> workPlaneGrid(const Scene& scene, double height, double spacing,
                                        double margin, const std::string& file,
                                        const std::string& place) {
  const auto at = [&](const char* option, const char* key) {
    return place.empty() ? std::string(option) : place + "." + key;
  };
  if (!(spacing > 0.0) || !std::isfinite(spacing)) {
    return inputError(file, at("--grid-spacing", "spacing"),
                      fmt::format("{} must be a positive length", spacing));
  }
  if (!(margin >= 0.0) || !std::isfinite(margin) || !std::isfinite(height)) {
    return inputError(file, at("--work-plane", "height"),
                      "height and margin must be finite, the margin >= 0");
  }
  glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-lo);
  for (const Mesh& m : scene.meshes) {
    for (const glm::vec3& p : m.positions) {
      lo = glm::min(lo, glm::dvec3(p));
      hi = glm::max(hi, glm::dvec3(p));
    }
  }
  if (!(lo.x <= hi.x)) return inputError(scene.source, "", "the scene has no geometry");
  const double x0 = lo.x + margin, x1 = hi.x - margin, z0 = lo.z + margin, z1 = hi.z - margin;
  if (!(x1 > x0 && z1 > z0)) {
    return inputError(file, at("--grid-margin", "margin"),
                      fmt::format("a margin of {} m leaves no area of the {:.3g} x {:.3g} m floor",
                                  margin, hi.x - lo.x, hi.z - lo.z));
  }
  const double cols = std::ceil((x1 - x0) / spacing - 1e-9);
  const double rows = std::ceil((z1 - z0) / spacing - 1e-9);
  if (cols * rows > double(kMaxCalculationPoints)) {
    return inputError(file, at("--grid-spacing", "spacing"),
                      fmt::format("{} m over {:.3g} x {:.3g} m makes {:.0f} points (at most 4 "
                                  "million)",
                                  spacing, x1 - x0, z1 - z0, cols * rows));
  }
  CalculationGrid g;
  g.name = fmt::format("work plane at {:.3g} m", height);
  g.type = "work_plane";
  g.columns = int(cols);
  g.rows = int(rows);
  g.spacing = spacing;
  const double dx = (x1 - x0) / cols, dz = (z1 - z0) / rows;
  for (int r = 0; r < g.rows; ++r) {
    for (int c = 0; c < g.columns; ++c) {
      g.points.emplace_back(x0 + (c + 0.5) * dx, lo.y + height, z0 + (r + 0.5) * dz);
      g.normals.emplace_back(0.0, 1.0, 0.0);
    }
  }
  return g;
}

Expected<CalculationGrid> surfaceGrid(const Scene& scene, const std::string& name, double spacing,
                                      const std::string& file, const std::string& place) {
  const auto at = [&](const char* option, const char* key) {
    return place.empty() ? std::string(option) : place + "." + key;
  };
  if (!(spacing > 0.0) || !std::isfinite(spacing)) {
    return inputError(file, at("--grid-spacing", "spacing"),
                      fmt::format("{} must be a positive length", spacing));
  }
  CalculationGrid g;
  g.name = fmt::format("surface '{}'", name);
  g.type = "surface";
  g.spacing = spacing;
  std::string known;
  bool found = false;
  double points = 0.0;
  for (const Mesh& m : scene.meshes) {
    if (m.name != name) {
      if (known.find("'" + m.name + "'") == std::string::npos) {
        known += (known.empty() ? "'" : ", '") + m.name + "'";
      }
      continue;
    }
    found = true;
    for (const glm::uvec3& t : m.triangles) {
      const glm::dvec3 a(m.positions[t.x]), b(m.positions[t.y]), c(m.positions[t.z]);
      const double edge = std::max({glm::length(b - a), glm::length(c - b), glm::length(a - c)});
      points += std::pow(std::ceil(edge / spacing), 2.0);
    }
  }
  if (!found) {
    return inputError(file.empty() ? scene.source : file, at("--grid-surface", "mesh"),
                      fmt::format("no mesh is named '{}' (the meshes: {})", name, known));
  }
  if (points > double(kMaxCalculationPoints)) {
    return inputError(
        file, at("--grid-spacing", "spacing"),
        fmt::format("{} m on '{}' makes {:.0f} points (at most 4 million)", spacing, name, points));
  }
  for (const Mesh& m : scene.meshes) {
    if (m.name != name) continue;
    for (const glm::uvec3& t : m.triangles) {
      const glm::dvec3 a(m.positions[t.x]), b(m.positions[t.y]), c(m.positions[t.z]);
      const glm::dvec3 cr = glm::cross(b - a, c - a);
      const double area2 = glm::length(cr);
      if (!(area2 > 0.0)) continue;  // degenerate: no area, no point
      const glm::dvec3 n = cr / area2;
      const int k = int(std::ceil(
          std::max({glm::length(b - a), glm::length(c - b), glm::length(a - c)}) / spacing));
      const glm::dvec3 u = (b - a) / double(k), v = (c - a) / double(k);
      const double share = 0.5 * area2 / double(k * k);
      // The k^2 similar triangles: k(k+1)/2 upright ones and k(k-1)/2 inverted.
      for (int i = 0; i < k; ++i) {
        for (int j = 0; i + j < k; ++j) {
          const glm::dvec3 o = a + double(i) * u + double(j) * v;
          g.points.push_back(o + (u + v) / 3.0);
          g.normals.push_back(n);
          g.areas.push_back(share);
          if (i + j + 1 < k) {
            g.points.push_back(o + 2.0 * (u + v) / 3.0);
            g.normals.push_back(n);
            g.areas.push_back(share);
          }
        }
      }
    }
  }
  g.columns = int(g.points.size());
  g.rows = 1;
  return g;
}

Expected<CalculationGrid> planeGrid(const std::string& name, const glm::dvec3& origin,
                                    const glm::dvec3& u, const glm::dvec3& v,
                                    const glm::dvec3& normal, double spacing, double margin,
                                    const std::string& file, const std::string& place) {
  const double lu = glm::length(u), lv = glm::length(v);
  if (!(lu > 0.0 && lv > 0.0)) return inputError(file, place, "u and v must not be zero");
  if (std::fabs(glm::dot(u, v)) > 1e-6 * lu * lv) {
    return inputError(file, place, "u and v must be square to each other");
  }
  if (std::fabs(glm::dot(normal, u)) > 1e-6 * lu || std::fabs(glm::dot(normal, v)) > 1e-6 * lv) {
    return inputError(file, keyOf(place, "normal"), "must be square to u and v");
  }
  if (!(spacing > 0.0)) {
    return inputError(file, keyOf(place, "spacing"), "must be a positive length");
  }
  const double su = lu - 2.0 * margin, sv = lv - 2.0 * margin;
  if (!(su > 0.0 && sv > 0.0)) {
    return inputError(file, keyOf(place, "margin"),
                      fmt::format("a margin of {} m leaves no area of the {:.3g} x {:.3g} m "
                                  "rectangle",
                                  margin, lu, lv));
  }
  const double cols = std::ceil(su / spacing - 1e-9), rows = std::ceil(sv / spacing - 1e-9);
  if (cols * rows > double(kMaxCalculationPoints)) {
    return inputError(file, keyOf(place, "spacing"),
                      fmt::format("{} m over {:.3g} x {:.3g} m makes {:.0f} points (at most 4 "
                                  "million)",
                                  spacing, su, sv, cols * rows));
  }
  CalculationGrid g;
  g.name = name;
  g.type = "grid";
  g.columns = int(cols);
  g.rows = int(rows);
  g.spacing = spacing;
  g.axis_u = u / lu;
  g.axis_v = v / lv;
  const glm::dvec3 start = origin + margin * (g.axis_u + g.axis_v);
  const double du = su / cols, dv = sv / rows;
  for (int r = 0; r < g.rows; ++r) {
    for (int c = 0; c < g.columns; ++c) {
      g.points.push_back(start + (c + 0.5) * du * g.axis_u + (r + 0.5) * dv * g.axis_v);
      g.normals.push_back(normal);
    }
  }
  return g;
}

Expected<std::vector<CalculationGrid>> calculationObjectsFromJson(const Scene& scene,
                                                                  const json& list,
                                                                  const std::string& file,
                                                                  const std::string& place) {
  const JsonReader r{file};
  if (!list.is_array()) {
    return r.error(
        place, fmt::format("must be an array of calculation objects, not {}", jsonTypeName(list)));
  }
  std::vector<CalculationGrid> out;
  size_t total = 0;
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string at = fmt::format("{}[{}]", place, i);
    const json& o = list[i];
    if (!o.is_object()) {
      return r.error(at, fmt::format("must be an object, not {}", jsonTypeName(o)));
    }
    if (!o.contains("type")) {
      return r.error(keyOf(at, "type"), "missing (work_plane, grid, surface, points or glare)");
    }
    Expected<std::string> type = r.string(o.at("type"), keyOf(at, "type"));
    if (!type) return type.error();
    std::string name = fmt::format("{} {}", *type, i + 1);
    if (o.contains("name")) {
      Expected<std::string> s = r.string(o.at("name"), keyOf(at, "name"));
      if (!s) return s.error();
      name = *s;
    }
    Measure measure = Measure::kPlanar;
    if (o.contains("measure")) {
      Expected<std::string> m = r.string(o.at("measure"), keyOf(at, "measure"));
      if (!m) return m.error();
      if (*m == "cylindrical") {
        measure = Measure::kCylindrical;
      } else if (*m != "planar") {
        return r.error(keyOf(at, "measure"), fmt::format("'{}' is not planar or cylindrical", *m));
      }
    }
    Expected<double> spacing = r.length(o, at, "spacing", 0.25, true);
    if (!spacing) return spacing.error();
    Expected<double> margin = r.length(o, at, "margin", 0.0, false);
    if (!margin) return margin.error();
    Expected<CalculationGrid> g = inputError(file, at, "");
    if (*type == "work_plane") {
      PENUMBRA_TRY(r.keys(o, at, {"type", "name", "measure", "height", "spacing", "margin"}));
      if (!o.contains("height")) return r.error(keyOf(at, "height"), "missing");
      Expected<double> h = r.number(o.at("height"), keyOf(at, "height"));
      if (!h) return h.error();
      g = workPlaneGrid(scene, *h, *spacing, *margin, file, at);
    } else if (*type == "grid") {
      g = gridObject(r, o, at, name, measure, *spacing, *margin);
    } else if (*type == "surface") {
      PENUMBRA_TRY(r.keys(o, at, {"type", "name", "measure", "mesh", "spacing"}));
      if (!o.contains("mesh")) return r.error(keyOf(at, "mesh"), "missing");
      Expected<std::string> mesh = r.string(o.at("mesh"), keyOf(at, "mesh"));
      if (!mesh) return mesh.error();
      g = surfaceGrid(scene, *mesh, *spacing, file, at);
    } else if (*type == "points") {
      PENUMBRA_TRY(r.keys(o, at, {"type", "name", "measure", "points", "file"}));
      if (o.contains("points") == o.contains("file")) {
        return r.error(at, "a points object has either \"points\" or \"file\"");
      }
      if (o.contains("file")) {
        Expected<std::string> f = r.string(o.at("file"), keyOf(at, "file"));
        if (!f) return f.error();
        g = readCalculationPoints(file.empty() ? *f : resolveRelativeTo(file, *f));
      } else {
        CalculationGrid p;
        p.type = "points";
        PENUMBRA_TRY(readPointList(r, o.at("points"), keyOf(at, "points"), p));
        if (p.points.empty()) return r.error(keyOf(at, "points"), "no calculation points");
        finishList(p);
        g = std::move(p);
      }
    } else if (*type == "glare") {
      PENUMBRA_TRY(r.keys(o, at, {"type", "name", "observers"}));
      if (!o.contains("observers")) return r.error(keyOf(at, "observers"), "missing");
      CalculationGrid p;
      p.type = "glare";
      PENUMBRA_TRY(readPointList(r, o.at("observers"), keyOf(at, "observers"), p, "view"));
      if (p.points.empty()) return r.error(keyOf(at, "observers"), "no observers");
      finishList(p);
      g = std::move(p);
    } else {
      return r.error(keyOf(at, "type"),
                     fmt::format("'{}' is not work_plane, grid, surface, points or glare", *type));
    }
    if (!g) return g.error();
    g->name = name;
    g->measure = measure;
    if (measure == Measure::kCylindrical && *type == "surface") {
      return r.error(keyOf(at, "measure"),
                     "cylindrical applies to planes and points, not to a "
                     "surface");
    }
    total += g->points.size();
    if (total > kMaxCalculationPoints) {
      return r.error(at, fmt::format("the objects make {} points (at most 4 million)", total));
    }
    out.push_back(std::move(*g));
  }
  return out;
}

Expected<std::vector<CalculationGrid>> readCalculationFile(const Scene& scene,
                                                           const std::string& path) {
  Expected<std::string> text = readFile(path);
  if (!text) return text.error();
  PENUMBRA_TRY(checkJsonNesting(path, *text, /*comments=*/true));
  const json root = json::parse(*text, nullptr, /*allow_exceptions=*/false,
                                /*ignore_comments=*/true);
  if (root.is_discarded()) return inputError(path, "", "not valid JSON");
  if (root.is_object()) {
    const JsonReader r{path};
    PENUMBRA_TRY(r.keys(root, "", {"calculation"}));
    if (!root.contains("calculation")) return inputError(path, "calculation", "missing");
    return calculationObjectsFromJson(scene, root.at("calculation"), path, "calculation");
  }
  return calculationObjectsFromJson(scene, root, path, "");
}

Expected<CalculationGrid> readCalculationPoints(const std::string& path) {
  Expected<std::string> text = readFile(path);
  if (!text) return text.error();
  CalculationGrid g;
  if (extensionOf(path) == ".json") {
    PENUMBRA_TRY(checkJsonNesting(path, *text, /*comments=*/true));
    const json root = json::parse(*text, nullptr, /*allow_exceptions=*/false,
                                  /*ignore_comments=*/true);
    if (root.is_discarded()) return inputError(path, "", "not valid JSON");
    const JsonReader r{path};
    g.type = "points";
    if (root.is_object()) {
      PENUMBRA_TRY(r.keys(root, "", {"points"}));
      if (!root.contains("points")) return inputError(path, "points", "missing");
      PENUMBRA_TRY(readPointList(r, root.at("points"), "points", g));
    } else {
      PENUMBRA_TRY(readPointList(r, root, "", g));
    }
    if (g.points.empty()) return inputError(path, "", "no calculation points");
  } else {
    Expected<CalculationGrid> csv = readPointsCsv(path, *text);
    if (!csv) return csv.error();
    g = std::move(*csv);
  }
  g.name = std::filesystem::path(path).stem().string();
  finishList(g);
  return g;
}

}  // namespace penumbra
