// A small canvas for the figures Penumbra writes next to its images: the polar plot of a
// luminaire's light distribution (`penumbra info FILE.ldt --plot`) and the legend of false-colour
// illuminance images. Display-linear colours in [0, 1], written as PNG without tone mapping
// (ToneMapOperator::kNone); text in stb_easy_font's built-in font (Debian's libstb).
#pragma once

#include "penumbra/core/image.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <string>
#include <vector>

namespace penumbra {

class Canvas {
 public:
  Canvas(int width, int height, glm::vec3 background = glm::vec3(1.0f));

  // An antialiased line `width` pixels wide (pixel centres at x + 0.5).
  void line(glm::vec2 a, glm::vec2 b, glm::vec3 colour, float width = 1.0f);
  // A polyline through `points`, closed when `closed`.
  void polyline(const std::vector<glm::vec2>& points, glm::vec3 colour, float width = 1.0f,
                bool closed = false);
  // A filled axis-aligned rectangle [x0, x1) x [y0, y1).
  void fillRect(int x0, int y0, int x1, int y1, glm::vec3 colour);
  // Text with its top-left corner at (x, y), each font pixel `scale` pixels wide; returns its
  // width in pixels.
  int text(int x, int y, const std::string& s, glm::vec3 colour, int scale = 2);
  // The width of `s` in pixels at `scale`.
  static int textWidth(const std::string& s, int scale = 2);

  const Image& image() const { return image_; }
  Image& image() { return image_; }

 private:
  void blend(int x, int y, glm::vec3 colour, float coverage);
  Image image_;
};

// The false-colour scale of illuminance images: blue (0) through cyan, green, yellow to red (1),
// display-linear; `t` is clamped to [0, 1].
glm::vec3 falseColour(float t);

struct Photometry;

// The light distribution curve of a luminaire as lighting catalogues draw it: intensity against
// gamma in the C0-C180 plane (red, C0 on the right) and the C90-C270 plane (blue, C90 on the
// right), the nadir down, in cd/klm of lamp flux (cd for absolute photometry), on a polar grid
// with round-numbered circles; `size` pixels square plus a caption.
Image luminairePolarPlot(const Photometry& photometry, int size = 640);

// A curve of a log-log plot: its name in the legend, colour and points (x, y > 0; others are
// left out).
struct PlotSeries {
  std::string name;
  glm::vec3 colour{0.0f};
  std::vector<glm::dvec2> points;
  bool dashed = false;
};

// Curves on log-log axes with a decade grid, axis labels, a title and a legend: how the docs
// show error against iterations or time. `width` x `height` pixels.
Image logLogPlot(const std::vector<PlotSeries>& series, const std::string& title,
                 const std::string& x_label, const std::string& y_label, int width = 720,
                 int height = 480);

// A round upper end for a scale reaching `value`: 1, 1.2, 1.5, 2, 2.5, 3, 4, 5, 6 or 8 times a
// power of ten.
double niceCeiling(double value);

}  // namespace penumbra
