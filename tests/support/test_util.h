// Helpers shared by the tests.
#pragma once

#include "penumbra/core/check.h"
#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/core/rng.h"
#include "penumbra/scene/luminaire.h"
#include "penumbra/scene/mesh.h"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include <string>

namespace penumbra {
class GlContext;
}

namespace penumbra::test {

// A fresh directory under the system temp dir, removed with its contents on destruction.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  // Writes `contents` to `name` inside the directory and returns its path.
  std::string write(const std::string& name, const std::string& contents) const;

 private:
  std::filesystem::path path_;
};

// Uniform point in the cube [lo, hi]^3.
inline glm::vec3 randomInBox(Rng& rng, float lo, float hi) {
  return glm::vec3(lo + (hi - lo) * rng.uniform(), lo + (hi - lo) * rng.uniform(),
                   lo + (hi - lo) * rng.uniform());
}

// Uniform direction on the unit sphere.
inline glm::vec3 randomDirection(Rng& rng) {
  const float z = 1.0f - 2.0f * rng.uniform();
  const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
  const float phi = 6.2831853f * rng.uniform();
  return glm::vec3(r * std::cos(phi), r * std::sin(phi), z);
}

// A made-up luminaire distribution, asymmetric in C and with an upward part, in cd:
//   I(C, g) = 1000 (1 + 0.5 cos C sin g) cos(g)^1.5 below the horizon, 150 sin(g - 90 deg) above
// it (one value at each pole, as a real distribution has).
double testLuminaireCandela(double c_degrees, double gamma_degrees);
// Its LDT on a 10-degree C by 5-degree gamma grid (36 x 37), aimed along `nadir` with C0 along
// `c0`, radiometric scale I_max / 683 (scene/luminaire.h).
LuminaireLight testLuminaire(glm::vec3 position = glm::vec3(0.1f, 1.3f, -0.2f),
                             glm::vec3 nadir = glm::vec3(0.0f, -1.0f, 0.0f),
                             glm::vec3 c0 = glm::vec3(1.0f, 0.0f, 0.0f));

// Path of a file under tests/data.
// Appends a quad (two triangles) with corners o, o + u, o + u + v, o + v to `m`, front face
// along u x v, both triangles of `material`.
inline void addQuad(Mesh& m, glm::vec3 o, glm::vec3 u, glm::vec3 v, uint32_t material) {
  const uint32_t b = uint32_t(m.positions.size());
  m.positions.insert(m.positions.end(), {o, o + u, o + u + v, o + v});
  m.triangles.emplace_back(b, b + 1, b + 2);
  m.triangles.emplace_back(b, b + 2, b + 3);
  m.material_ids.insert(m.material_ids.end(), {material, material});
}

// RFC 4648 base64 (for data: URIs in glTF files written by tests).
// A binary glTF (GLB, glTF 2.0 sec. 4.4): the JSON chunk and the BIN chunk, each padded to 4 bytes.
std::string glbBytes(const nlohmann::json& doc, const std::string& bin);

// The bilinear lookup of `image` at `uv` (glTF convention: (0, 0) the top-left corner, texel
// centres at half-integers), clamped to the edge, as a GPU's linear sampler reads a lightmap.
inline glm::vec3 bilinear(const Image& image, glm::vec2 uv) {
  const float fx = uv.x * float(image.width) - 0.5f, fy = uv.y * float(image.height) - 0.5f;
  const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
  const float ax = fx - float(x0), ay = fy - float(y0);
  auto at = [&](int x, int y) {
    return image.at(std::clamp(x, 0, image.width - 1), std::clamp(y, 0, image.height - 1));
  };
  return (at(x0, y0) * (1 - ax) + at(x0 + 1, y0) * ax) * (1 - ay) +
         (at(x0, y0 + 1) * (1 - ax) + at(x0 + 1, y0 + 1) * ax) * ay;
}

// Appends the bytes of `values` to a buffer (a glTF .bin made by hand).
template <typename T>
void appendBytes(std::string& buf, std::initializer_list<T> values) {
  for (T v : values) buf.append(reinterpret_cast<const char*>(&v), sizeof(T));
}

inline std::string base64(const std::string& in) {
  static const char* const kChars =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const uint32_t v = (uint8_t(in[i]) << 16) | (uint8_t(in[i + 1]) << 8) | uint8_t(in[i + 2]);
    for (int k = 3; k >= 0; --k) out += kChars[(v >> (6 * k)) & 63];
  }
  if (i + 1 == in.size()) {
    const uint32_t v = uint8_t(in[i]) << 16;
    out += kChars[(v >> 18) & 63];
    out += kChars[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == in.size()) {
    const uint32_t v = (uint8_t(in[i]) << 16) | (uint8_t(in[i + 1]) << 8);
    out += kChars[(v >> 18) & 63];
    out += kChars[(v >> 12) & 63];
    out += kChars[(v >> 6) & 63];
    out += "=";
  }
  return out;
}

// A closed box [0, w] x [0, h] x [0, d] (metres), faces wound outwards, of one material.
inline Mesh boxMesh(double w, double h, double d) {
  Mesh m;
  m.name = "box";
  const glm::vec3 p[8] = {{0, 0, 0},
                          {float(w), 0, 0},
                          {float(w), float(h), 0},
                          {0, float(h), 0},
                          {0, 0, float(d)},
                          {float(w), 0, float(d)},
                          {float(w), float(h), float(d)},
                          {0, float(h), float(d)}};
  m.positions.assign(p, p + 8);
  const glm::uvec4 quads[6] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                               {3, 7, 6, 2}, {0, 4, 7, 3}, {1, 2, 6, 5}};
  for (const glm::uvec4& q : quads) {
    m.triangles.emplace_back(q.x, q.y, q.z);
    m.triangles.emplace_back(q.x, q.z, q.w);
  }
  m.material_ids.assign(m.triangles.size(), 0);
  return m;
}

inline std::string dataPath(const std::string& relative) {
  return std::string(PENUMBRA_TEST_DATA) + "/" + relative;
}

// Succeeds when `result` is an error whose description names `file` and `place`.
template <typename T>
::testing::AssertionResult errorNames(const Expected<T>& result, const std::string& file,
                                      const std::string& place) {
  if (result.ok()) return ::testing::AssertionFailure() << "loaded, but an error was expected";
  const std::string d = result.error().describe();
  if (d.find(file) == std::string::npos || d.find(place) == std::string::npos) {
    return ::testing::AssertionFailure()
           << "'" << d << "' does not name '" << file << "' and '" << place << "'";
  }
  return ::testing::AssertionSuccess() << d;
}

// A headless OpenGL context for this test process, made once; nullptr (with `why`) when none
// can be made.
GlContext* glContext(std::string& why);

// A JSON file's contents (a stats file); a file that does not parse throws, failing the test.
nlohmann::json readJson(const std::string& path);

// Result of running the penumbra executable.
struct CliResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

// Runs build/bin/penumbra with `args` (a shell-quoted argument string), with `env` ("NAME=value
// ...") added to its environment.
CliResult runCli(const std::string& args, const std::string& env = "");
// Runs `command` with /bin/sh; its stdout (add 2>&1 for stderr too) and exit code.
CliResult runShell(const std::string& command);

// That `work` throws InternalError (a broken PENUMBRA_CHECK, core/check.h) whose message
// contains `expected`.
template <typename Work>
void expectInternalError(Work&& work, const std::string& expected) {
  try {
    work();
    ADD_FAILURE() << "no InternalError (expected one naming '" << expected << "')";
  } catch (const InternalError& e) {
    EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
  }
}

}  // namespace penumbra::test

namespace penumbra {
class GlContext;
bool glRequired();
}  // namespace penumbra

// Makes the test's OpenGL context current, or skips the test when none can be made; under
// PENUMBRA_REQUIRE_GL=1 (CI) a missing context fails it instead.
#define PENUMBRA_GL_OR_SKIP()                                     \
  do {                                                            \
    std::string penumbra_why_;                                    \
    if (!::penumbra::test::glContext(penumbra_why_)) {            \
      if (::penumbra::glRequired()) FAIL() << penumbra_why_;      \
      GTEST_SKIP() << "no OpenGL 4.5 context: " << penumbra_why_; \
    }                                                             \
  } while (false)
