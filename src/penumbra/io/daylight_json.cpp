#include "penumbra/io/daylight_json.h"

#include "penumbra/io/json_reader.h"
#include "penumbra/scene/luminaire.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include <cmath>
#include <cstdio>

namespace penumbra {

namespace {

using nlohmann::json;

// "YYYY-MM-DD" and "HH:MM[:SS]", checked.
Status readDateTime(const JsonReader& r, const json& sun, const std::string& place, int& y, int& m,
                    int& d, double& hours) {
  for (const char* key : {"date", "time"}) {
    if (!sun.contains(key)) return r.error(keyOf(place, key), "missing");
  }
  Expected<std::string> date = r.string(sun.at("date"), keyOf(place, "date"));
  if (!date) return date.error();
  Expected<std::string> time = r.string(sun.at("time"), keyOf(place, "time"));
  if (!time) return time.error();
  char extra = 0;
  if (std::sscanf(date->c_str(), "%d-%d-%d%c", &y, &m, &d, &extra) != 3 || y < 1800 || y > 2200 ||
      m < 1 || m > 12 || d < 1 || d > 31) {
    return r.error(keyOf(place, "date"),
                   fmt::format("'{}' is not a date YYYY-MM-DD between 1800 and 2200", *date));
  }
  int hh = 0, mm = 0, ss = 0;
  const int n = std::sscanf(time->c_str(), "%d:%d:%d%c", &hh, &mm, &ss, &extra);
  if ((n != 2 && n != 3) || hh < 0 || hh > 24 || mm < 0 || mm > 59 || ss < 0 || ss > 59) {
    return r.error(keyOf(place, "time"), fmt::format("'{}' is not a time HH:MM[:SS]", *time));
  }
  hours = hh + mm / 60.0 + ss / 3600.0;
  return {};
}

}  // namespace

Expected<DaylightSky> readSky(const json& j, const std::string& file, const std::string& place) {
  const JsonReader r{file};
  if (!j.is_object()) {
    return r.error(place, fmt::format("must be an object, not {}", jsonTypeName(j)));
  }
  PENUMBRA_TRY(r.keys(j, place,
                      {"type", "zenith_luminance", "horizontal_illuminance", "sun",
                       "sun_illuminance", "ground_reflectance", "north"}));
  DaylightSky out;
  Sky& sky = out.sky;
  Expected<double> type = r.numberIn(j, place, "type", 16, 1, 16);
  if (!type) return type.error();
  if (*type != std::floor(*type)) {
    return r.error(keyOf(place, "type"), fmt::format("{} is not a whole number", *type));
  }
  sky.type = int(*type);
  Expected<double> rho = r.numberIn(j, place, "ground_reflectance", 0.2, 0.0, 1.0);
  if (!rho) return rho.error();
  sky.ground_reflectance = *rho;
  Expected<double> beam = r.numberIn(j, place, "sun_illuminance", 0.0, 0.0, 2e5);
  if (!beam) return beam.error();
  sky.sun_illuminance = *beam;
  if (j.contains("north")) {
    Expected<glm::dvec3> n = r.direction(j.at("north"), keyOf(place, "north"));
    if (!n) return n.error();
    if (std::fabs(n->y) > 0.999) {
      return r.error(keyOf(place, "north"), "must not point up or down");
    }
    sky.north = *n;
  }
  if (j.contains("sun")) {
    const std::string at = keyOf(place, "sun");
    const json& sun = j.at("sun");
    if (!sun.is_object()) {
      return r.error(at, fmt::format("must be an object, not {}", jsonTypeName(sun)));
    }
    if (sun.contains("elevation_deg") || sun.contains("azimuth_deg")) {
      PENUMBRA_TRY(r.keys(sun, at, {"elevation_deg", "azimuth_deg"}));
      Expected<double> el = r.numberIn(sun, at, "elevation_deg", 45.0, 0.0, 90.0);
      if (!el) return el.error();
      Expected<double> az = r.numberIn(sun, at, "azimuth_deg", 180.0, -360.0, 360.0);
      if (!az) return az.error();
      sky.sun_elevation_deg = *el;
      sky.sun_azimuth_deg = *az;
    } else {
      PENUMBRA_TRY(r.keys(sun, at, {"latitude", "longitude", "date", "time", "utc_offset"}));
      Expected<double> lat = r.numberIn(sun, at, "latitude", 0.0, -90.0, 90.0);
      if (!lat) return lat.error();
      Expected<double> lon = r.numberIn(sun, at, "longitude", 0.0, -180.0, 180.0);
      if (!lon) return lon.error();
      Expected<double> utc = r.numberIn(sun, at, "utc_offset", 0.0, -14.0, 14.0);
      if (!utc) return utc.error();
      int y = 0, m = 0, d = 0;
      double hours = 0.0;
      PENUMBRA_TRY(readDateTime(r, sun, at, y, m, d, hours));
      const SunPosition p = sunPosition(y, m, d, hours, *utc, *lat, *lon);
      if (p.elevation_deg <= 0.0) {
        return r.error(at, fmt::format("the sun is {:.1f} degrees below the horizon then: the "
                                       "CIE skies need it above",
                                       -p.elevation_deg));
      }
      sky.sun_elevation_deg = p.elevation_deg;
      sky.sun_azimuth_deg = p.azimuth_deg;
    }
  }
  if (j.contains("zenith_luminance") && j.contains("horizontal_illuminance")) {
    return r.error(place, "give zenith_luminance or horizontal_illuminance, not both");
  }
  Expected<double> lz = r.numberIn(j, place, "zenith_luminance", -1.0, 0.0, 1e9);
  if (!lz) return lz.error();
  Expected<double> eh = r.numberIn(j, place, "horizontal_illuminance", 10000.0, 0.0, 1e9);
  if (!eh) return eh.error();
  sky.prepare();  // E_h / L_z does not depend on the level
  sky.zenith_luminance = *lz >= 0.0 ? *lz : *eh / sky.horizontalPerZenith();
  if (sky.sun_illuminance > 0.0) {
    DirectionalLight sun;
    sun.direction = glm::vec3(-sky.sunDirection());
    sun.irradiance = glm::vec3(float(sky.sun_illuminance / kLumensPerWatt));
    out.sun = sun;
  }
  return out;
}

Expected<std::vector<Opening>> readOpenings(const json& j, const std::string& file,
                                            const std::string& place) {
  const JsonReader r{file};
  if (!j.is_array()) {
    return r.error(place, fmt::format("must be an array of openings, not {}", jsonTypeName(j)));
  }
  std::vector<Opening> out;
  for (size_t i = 0; i < j.size(); ++i) {
    const std::string at = fmt::format("{}[{}]", place, i);
    const json& o = j[i];
    if (!o.is_object())
      return r.error(at, fmt::format("must be an object, not {}", jsonTypeName(o)));
    PENUMBRA_TRY(r.keys(o, at, {"name", "corners", "glazing"}));
    Opening op;
    op.name = fmt::format("opening {}", i + 1);
    if (o.contains("name")) {
      Expected<std::string> s = r.string(o.at("name"), keyOf(at, "name"));
      if (!s) return s.error();
      op.name = *s;
    }
    if (!o.contains("corners")) return r.error(keyOf(at, "corners"), "missing");
    const json& c = o.at("corners");
    if (!c.is_array() || c.size() < 3 || c.size() > 16) {
      return r.error(keyOf(at, "corners"), "must be an array of 3 to 16 corners");
    }
    for (size_t k = 0; k < c.size(); ++k) {
      Expected<glm::dvec3> p = r.vec3(c[k], fmt::format("{}.corners[{}]", at, k));
      if (!p) return p.error();
      op.corners.push_back(*p);
    }
    // Planar and convex, with area: every fan triangle's normal along the first's.
    glm::dvec3 n(0.0);
    for (size_t k = 1; k + 1 < op.corners.size(); ++k) {
      n += glm::cross(op.corners[k] - op.corners[0], op.corners[k + 1] - op.corners[0]);
    }
    const double area2 = glm::length(n);
    double extent = 0.0;
    for (const glm::dvec3& p : op.corners)
      extent = std::max(extent, glm::length(p - op.corners[0]));
    if (!(area2 > 1e-12 * extent * extent)) {
      return r.error(keyOf(at, "corners"), "the corners enclose no area");
    }
    n /= area2;
    for (size_t k = 0; k < op.corners.size(); ++k) {
      const glm::dvec3 a = op.corners[k], b = op.corners[(k + 1) % op.corners.size()],
                       e = op.corners[(k + 2) % op.corners.size()];
      if (std::fabs(glm::dot(n, a - op.corners[0])) > 1e-6 * extent ||
          glm::dot(glm::cross(b - a, e - b), n) < -1e-9 * extent * extent) {
        return r.error(keyOf(at, "corners"), "must be a flat convex polygon, in order");
      }
    }
    if (o.contains("glazing")) {
      const json& g = o.at("glazing");
      const std::string gp = keyOf(at, "glazing");
      if (!g.is_object())
        return r.error(gp, fmt::format("must be an object, not {}", jsonTypeName(g)));
      PENUMBRA_TRY(r.keys(g, gp, {"transmittance", "ior", "falloff"}));
      Expected<double> t = r.numberIn(g, gp, "transmittance", 0.878, 0.0, 1.0);
      if (!t) return t.error();
      Expected<double> ior = r.numberIn(g, gp, "ior", 1.52, 1.0, 4.0);
      if (!ior) return ior.error();
      if (g.contains("falloff")) {
        Expected<std::string> f = r.string(g.at("falloff"), keyOf(gp, "falloff"));
        if (!f) return f.error();
        if (*f == "clear_glass") {
          op.falloff = GlazingFalloff::kClearGlass;
        } else if (*f != "fresnel") {
          return r.error(keyOf(gp, "falloff"),
                         fmt::format("'{}' is not fresnel or clear_glass", *f));
        }
      }
      op.glazed = true;
      op.transmittance = *t;
      op.ior = *ior;
    }
    out.push_back(std::move(op));
  }
  return out;
}

}  // namespace penumbra
