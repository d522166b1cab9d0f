#include "penumbra/subsurface/lpv_sh.h"

#include <glm/geometric.hpp>

#include <cmath>
#include <numbers>

namespace penumbra {

namespace {

constexpr double kY0 = 0.28209479177387814;  // 1 / sqrt(4 pi)
constexpr double kY1 = 0.48860251190291992;  // sqrt(3 / (4 pi))

// Gauss-Legendre nodes and weights on [-1, 1], 16 points.
constexpr int kGauss = 16;
constexpr double kNodes[kGauss / 2] = {0.0950125098376374, 0.2816035507792589, 0.4580167776572274,
                                       0.6178762444026438, 0.7554044083550030, 0.8656312023878318,
                                       0.9445750230732326, 0.9894009349916499};
constexpr double kWeights[kGauss / 2] = {0.1894506104550685, 0.1826034150449236, 0.1691565193950025,
                                         0.1495959888165767, 0.1246289712555339, 0.0951585116824928,
                                         0.0622535239386479, 0.0271524594117541};

// integral over the solid angle of the square face (centre c, outward-from-cell normal n, edge
// vectors a and b spanning it, each of length 1) of y(w) dw, seen from the origin: composite
// Gauss-Legendre over 2 x 2 panels (the integrand is smooth: 8 x 8 panels agree to 1e-15).
glm::dvec4 faceIntegral(const glm::dvec3& c, const glm::dvec3& a, const glm::dvec3& b) {
  constexpr int kPanels = 2;
  glm::dvec4 sum(0.0);
  const glm::dvec3 normal = glm::normalize(glm::cross(a, b));
  for (int pu = 0; pu < kPanels; ++pu) {
    for (int pv = 0; pv < kPanels; ++pv) {
      for (int i = 0; i < kGauss; ++i) {
        const double xi = i < kGauss / 2 ? -kNodes[kGauss / 2 - 1 - i] : kNodes[i - kGauss / 2];
        const double wi = i < kGauss / 2 ? kWeights[kGauss / 2 - 1 - i] : kWeights[i - kGauss / 2];
        for (int j = 0; j < kGauss; ++j) {
          const double xj = j < kGauss / 2 ? -kNodes[kGauss / 2 - 1 - j] : kNodes[j - kGauss / 2];
          const double wj =
              j < kGauss / 2 ? kWeights[kGauss / 2 - 1 - j] : kWeights[j - kGauss / 2];
          // (u, v) in [-1/2, 1/2]^2 over the face.
          const double u = -0.5 + (pu + 0.5 * (xi + 1.0)) / kPanels;
          const double v = -0.5 + (pv + 0.5 * (xj + 1.0)) / kPanels;
          const glm::dvec3 p = c + u * a + v * b;
          const double r2 = glm::dot(p, p), r = std::sqrt(r2);
          const glm::dvec3 w = p / r;
          // dw = |cos| dA / r^2, dA = (1 / kPanels)^2 / 4 wi wj.
          const double d_area = wi * wj * 0.25 / double(kPanels * kPanels);
          sum += lpvBasis(w) * (std::abs(glm::dot(normal, w)) / r2 * d_area);
        }
      }
    }
  }
  return sum;
}

std::array<glm::dmat4, 6> derive() {
  std::array<glm::dmat4, 6> out{};
  for (size_t k = 0; k < kLpvDirections.size(); ++k) {
    // The source at the origin, the destination cell centred at one cell along the direction.
    const glm::dvec3 dir(kLpvDirections[k]);
    const glm::dvec3 centre = dir;
    glm::dmat4 m(0.0);
    for (int axis = 0; axis < 3; ++axis) {
      for (int side = -1; side <= 1; side += 2) {
        glm::dvec3 n(0.0);
        n[axis] = double(side);
        if (n == -dir) continue;  // the face the two cells share
        glm::dvec3 a(0.0), b(0.0);
        a[(axis + 1) % 3] = 1.0;
        b[(axis + 2) % 3] = 1.0;
        const glm::dvec4 v = faceIntegral(centre + 0.5 * n, a, b);
        const glm::dvec4 lobe = lpvCosineLobe(n) / std::numbers::pi;
        // M[i][j] = lobe_i v_j: column j is lobe * v_j.
        for (int j = 0; j < 4; ++j) m[j] += lobe * v[j];
      }
    }
    out[k] = m;
  }
  return out;
}

}  // namespace

glm::dvec4 lpvBasis(const glm::dvec3& w) {
  return glm::dvec4(kY0, kY1 * w.y, kY1 * w.z, kY1 * w.x);
}

glm::dvec4 lpvCosineLobe(const glm::dvec3& n) {
  // integral_2pi cos y00 = pi / sqrt(4 pi); integral_2pi cos^2 sqrt(3 / (4 pi)) = sqrt(3 / (4 pi))
  // 2 pi / 3 = sqrt(pi / 3).
  const double a0 = std::sqrt(std::numbers::pi) / 2.0, a1 = std::sqrt(std::numbers::pi / 3.0);
  return glm::dvec4(a0, a1 * n.y, a1 * n.z, a1 * n.x);
}

const std::array<glm::dmat4, 6>& lpvPropagationMatrices() {
  static const std::array<glm::dmat4, 6> matrices = derive();
  return matrices;
}

double lpvAreaLightRadiance(const glm::dvec4& c, const glm::dvec3& n, double area) {
  const double c10n = n.x * c.w + n.y * c.y + n.z * c.z;
  return 2.0 / area * (kY0 * c.x + 0.5 * kY1 * c10n);
}

}  // namespace penumbra
