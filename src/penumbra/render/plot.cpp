#include "penumbra/render/plot.h"

#include "penumbra/io/photometry.h"

#include <fmt/format.h>
#include <stb/stb_easy_font.h>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>

namespace penumbra {

Canvas::Canvas(int width, int height, glm::vec3 background) : image_(width, height) {
  std::fill(image_.pixels.begin(), image_.pixels.end(), background);
}

void Canvas::blend(int x, int y, glm::vec3 colour, float coverage) {
  if (x < 0 || y < 0 || x >= image_.width || y >= image_.height || !(coverage > 0.0f)) return;
  glm::vec3& p = image_.at(x, y);
  p = glm::mix(p, colour, std::min(coverage, 1.0f));
}

void Canvas::line(glm::vec2 a, glm::vec2 b, glm::vec3 colour, float width) {
  // Coverage from the distance of each pixel centre to the segment: 1 within half the width,
  // falling to 0 over one pixel beyond it.
  const float r = 0.5f * width;
  const int x0 = int(std::floor(std::min(a.x, b.x) - r - 1.0f));
  const int x1 = int(std::ceil(std::max(a.x, b.x) + r + 1.0f));
  const int y0 = int(std::floor(std::min(a.y, b.y) - r - 1.0f));
  const int y1 = int(std::ceil(std::max(a.y, b.y) + r + 1.0f));
  const glm::vec2 ab = b - a;
  const float len2 = glm::dot(ab, ab);
  for (int y = std::max(0, y0); y <= std::min(image_.height - 1, y1); ++y) {
    for (int x = std::max(0, x0); x <= std::min(image_.width - 1, x1); ++x) {
      const glm::vec2 p(float(x) + 0.5f, float(y) + 0.5f);
      const float t = len2 > 0.0f ? std::clamp(glm::dot(p - a, ab) / len2, 0.0f, 1.0f) : 0.0f;
      const float d = glm::length(p - (a + t * ab));
      blend(x, y, colour, std::clamp(r + 0.5f - d, 0.0f, 1.0f));
    }
  }
}

void Canvas::polyline(const std::vector<glm::vec2>& points, glm::vec3 colour, float width,
                      bool closed) {
  for (size_t i = 0; i + 1 < points.size(); ++i) line(points[i], points[i + 1], colour, width);
  if (closed && points.size() > 2) line(points.back(), points.front(), colour, width);
}

void Canvas::fillRect(int x0, int y0, int x1, int y1, glm::vec3 colour) {
  for (int y = std::max(0, y0); y < std::min(image_.height, y1); ++y) {
    for (int x = std::max(0, x0); x < std::min(image_.width, x1); ++x) image_.at(x, y) = colour;
  }
}

int Canvas::text(int x, int y, const std::string& s, glm::vec3 colour, int scale) {
  // stb_easy_font emits quads (4 vertices of x, y, z floats and 4 colour bytes) on a grid of
  // whole font pixels; each quad is a filled rectangle.
  std::vector<char> buffer(s.size() * 1024 + 64);  // stb: about 270 bytes a character
  std::string copy = s;
  const int quads =
      stb_easy_font_print(0.0f, 0.0f, copy.data(), nullptr, buffer.data(), int(buffer.size()));
  const float* v = reinterpret_cast<const float*>(buffer.data());
  for (int q = 0; q < quads; ++q) {
    const float* quad = v + size_t(q) * 16;  // 4 vertices x 4 floats (16 bytes each)
    float qx0 = quad[0], qy0 = quad[1], qx1 = quad[0], qy1 = quad[1];
    for (int k = 1; k < 4; ++k) {
      qx0 = std::min(qx0, quad[4 * k]);
      qx1 = std::max(qx1, quad[4 * k]);
      qy0 = std::min(qy0, quad[4 * k + 1]);
      qy1 = std::max(qy1, quad[4 * k + 1]);
    }
    fillRect(x + int(qx0) * scale, y + int(qy0) * scale, x + int(qx1) * scale, y + int(qy1) * scale,
             colour);
  }
  return textWidth(s, scale);
}

int Canvas::textWidth(const std::string& s, int scale) {
  std::string copy = s;
  return stb_easy_font_width(copy.data()) * scale;
}

glm::vec3 falseColour(float t) {
  // Piecewise linear through blue, cyan, green, yellow, red (the lighting designers' scale).
  static const glm::vec3 stops[5] = {{0.0f, 0.0f, 1.0f},
                                     {0.0f, 1.0f, 1.0f},
                                     {0.0f, 1.0f, 0.0f},
                                     {1.0f, 1.0f, 0.0f},
                                     {1.0f, 0.0f, 0.0f}};
  if (!(t > 0.0f)) return stops[0];
  if (t >= 1.0f) return stops[4];
  const float x = t * 4.0f;
  const int i = std::min(int(x), 3);
  return glm::mix(stops[i], stops[i + 1], x - float(i));
}

Image luminairePolarPlot(const Photometry& p, int size) {
  constexpr double kPi = 3.14159265358979323846;
  const bool relative = p.lamp_flux > 0.0;
  const double unit = relative ? 1000.0 / p.lamp_flux : 1.0;  // cd -> cd/klm
  // The planes' curves, sampled every half degree of gamma.
  struct Curve {
    double c_right, c_left;
    glm::vec3 colour;
  };
  const Curve curves[2] = {{0.0, 180.0, {0.85f, 0.1f, 0.1f}}, {90.0, 270.0, {0.1f, 0.25f, 0.85f}}};
  double peak = 0.0;
  for (const Curve& c : curves) {
    for (int g = 0; g <= 360; ++g) {
      peak = std::max(
          {peak, p.intensity(c.c_right, 0.5 * g) * unit, p.intensity(c.c_left, 0.5 * g) * unit});
    }
  }
  const double top = niceCeiling(peak);
  const int caption = 56;
  Canvas canvas(size, size + caption);
  const glm::vec2 centre(0.5f * float(size), 0.5f * float(size));
  const float radius = 0.42f * float(size);
  const glm::vec3 grid(0.75f), ink(0.0f);
  // Circles at quarters of the scale, radial lines every 30 degrees.
  for (int k = 1; k <= 4; ++k) {
    std::vector<glm::vec2> circle;
    for (int a = 0; a < 360; ++a) {
      const double t = a * kPi / 180.0;
      circle.emplace_back(centre.x + float(k) / 4.0f * radius * float(std::cos(t)),
                          centre.y + float(k) / 4.0f * radius * float(std::sin(t)));
    }
    canvas.polyline(circle, grid, 1.0f, true);
    canvas.text(int(centre.x) + 3, int(centre.y - float(k) / 4.0f * radius) + 2,
                fmt::format("{:g}", top * k / 4.0), glm::vec3(0.4f), 1);
  }
  for (int a = 0; a < 360; a += 30) {
    const double t = a * kPi / 180.0;
    canvas.line(centre, centre + radius * glm::vec2(float(std::sin(t)), float(std::cos(t))), grid);
    const int g = a <= 180 ? a : 360 - a;
    const glm::vec2 at = centre + 1.1f * radius * glm::vec2(float(std::sin(t)), float(std::cos(t)));
    const std::string label = fmt::format("{}", g);
    canvas.text(int(at.x) - Canvas::textWidth(label, 1) / 2, int(at.y) - 4, label, ink, 1);
  }
  // The curves: gamma from the nadir (down), C_right on the right half, C_left on the left.
  for (const Curve& c : curves) {
    for (int side = 0; side < 2; ++side) {
      std::vector<glm::vec2> points;
      for (int g = 0; g <= 360; ++g) {
        const double gamma = 0.5 * g, t = gamma * kPi / 180.0;
        const double v = p.intensity(side == 0 ? c.c_right : c.c_left, gamma) * unit;
        const float r = float(v / top) * radius;
        points.emplace_back(centre.x + (side == 0 ? 1.0f : -1.0f) * r * float(std::sin(t)),
                            centre.y + r * float(std::cos(t)));
      }
      canvas.polyline(points, c.colour, 2.0f);
    }
  }
  // Caption: the luminaire, the planes' colours, the unit.
  const int y0 = size + 4;
  std::string name = p.luminaire.empty() ? p.file : p.luminaire;
  if (name.size() > 70) name = name.substr(0, 67) + "...";
  canvas.text(8, y0, name, ink, 2);
  int x = 8;
  x += canvas.text(x, y0 + 26, "C0-C180", curves[0].colour, 2) + 16;
  x += canvas.text(x, y0 + 26, "C90-C270", curves[1].colour, 2) + 16;
  canvas.text(x, y0 + 26, relative ? "cd/klm" : "cd", ink, 2);
  return canvas.image();
}

Image logLogPlot(const std::vector<PlotSeries>& series, const std::string& title,
                 const std::string& x_label, const std::string& y_label, int width, int height) {
  // The decades that hold every point.
  double x0 = INFINITY, x1 = 0.0, y0 = INFINITY, y1 = 0.0;
  for (const PlotSeries& s : series) {
    for (const glm::dvec2& p : s.points) {
      if (!(p.x > 0.0 && p.y > 0.0 && std::isfinite(p.x) && std::isfinite(p.y))) continue;
      x0 = std::min(x0, p.x);
      x1 = std::max(x1, p.x);
      y0 = std::min(y0, p.y);
      y1 = std::max(y1, p.y);
    }
  }
  if (!(x1 > 0.0)) x0 = 1.0, x1 = 10.0, y0 = 1.0, y1 = 10.0;
  const double lx0 = std::floor(std::log10(x0)), lx1 = std::max(std::ceil(std::log10(x1)), lx0 + 1);
  const double ly0 = std::floor(std::log10(y0)), ly1 = std::max(std::ceil(std::log10(y1)), ly0 + 1);
  Canvas canvas(width, height);
  const glm::vec3 grid(0.85f), ink(0.0f);
  const float left = 90.0f, right = float(width) - 20.0f, top = 48.0f,
              bottom = float(height) - 60.0f;
  const auto at = [&](glm::dvec2 p) {
    return glm::vec2(left + float((std::log10(p.x) - lx0) / (lx1 - lx0)) * (right - left),
                     bottom - float((std::log10(p.y) - ly0) / (ly1 - ly0)) * (bottom - top));
  };
  // Decade grid lines and their labels, with the 2..9 lines fainter.
  for (double d = lx0; d <= lx1 + 1e-9; d += 1.0) {
    for (int m = 1; m <= 9 && d + std::log10(double(m)) <= lx1 + 1e-9; ++m) {
      const float x = at(glm::dvec2(double(m) * std::pow(10.0, d), std::pow(10.0, ly0))).x;
      canvas.line({x, top}, {x, bottom}, m == 1 ? grid * 0.9f : grid, 1.0f);
    }
    const std::string label = fmt::format("{:g}", std::pow(10.0, d));
    const float x = at(glm::dvec2(std::pow(10.0, d), std::pow(10.0, ly0))).x;
    canvas.text(int(x) - Canvas::textWidth(label) / 2, int(bottom) + 8, label, ink);
  }
  for (double d = ly0; d <= ly1 + 1e-9; d += 1.0) {
    for (int m = 1; m <= 9 && d + std::log10(double(m)) <= ly1 + 1e-9; ++m) {
      const float y = at(glm::dvec2(std::pow(10.0, lx0), double(m) * std::pow(10.0, d))).y;
      canvas.line({left, y}, {right, y}, m == 1 ? grid * 0.9f : grid, 1.0f);
    }
    const std::string label = fmt::format("{:g}", std::pow(10.0, d));
    const float y = at(glm::dvec2(std::pow(10.0, lx0), std::pow(10.0, d))).y;
    canvas.text(int(left) - 8 - Canvas::textWidth(label), int(y) - 6, label, ink);
  }
  canvas.polyline({{left, top}, {right, top}, {right, bottom}, {left, bottom}}, ink, 1.0f, true);
  canvas.text((width - Canvas::textWidth(title)) / 2, 4, title, ink);
  canvas.text((width - Canvas::textWidth(x_label)) / 2, int(bottom) + 32, x_label, ink);
  canvas.text(int(left), int(top) - 18, y_label, ink);
  // The curves, and the legend in the top right corner.
  int legend_y = int(top) + 10;
  for (const PlotSeries& s : series) {
    std::vector<glm::vec2> pts;
    for (const glm::dvec2& p : s.points) {
      if (p.x > 0.0 && p.y > 0.0 && std::isfinite(p.x) && std::isfinite(p.y)) pts.push_back(at(p));
    }
    if (s.dashed) {
      for (size_t k = 0; k + 1 < pts.size(); k += 2)
        canvas.line(pts[k], pts[k + 1], s.colour, 2.0f);
    } else {
      canvas.polyline(pts, s.colour, 2.0f);
    }
    const int w = Canvas::textWidth(s.name);
    canvas.line({right - float(w) - 50.0f, float(legend_y) + 6.0f},
                {right - float(w) - 20.0f, float(legend_y) + 6.0f}, s.colour, 2.0f);
    canvas.text(int(right) - w - 12, legend_y, s.name, ink);
    legend_y += 20;
  }
  return canvas.image();
}

double niceCeiling(double value) {
  if (!(value > 0.0) || !std::isfinite(value)) return 1.0;
  const double p = std::pow(10.0, std::floor(std::log10(value)));
  for (double m : {1.0, 1.2, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0}) {
    if (m * p >= value * (1.0 - 1e-12)) return m * p;
  }
  return 10.0 * p;
}

}  // namespace penumbra
