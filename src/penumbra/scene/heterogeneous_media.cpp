#include "penumbra/scene/heterogeneous_media.h"

#include "penumbra/core/file_util.h"
#include "penumbra/scene/material.h"

#include <fmt/format.h>
#include <glm/common.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <numbers>
#include <sstream>

namespace penumbra {

namespace {

constexpr const char* kMagic = "penumbra-medium 1";
constexpr int kFloats = 7;

// Value noise in [0, 1): a hash per lattice point, smoothstep-interpolated trilinearly.
double lattice(int x, int y, int z) {
  uint32_t h = uint32_t(x) * 0x8da6b343u ^ uint32_t(y) * 0xd8163841u ^ uint32_t(z) * 0xcb1ab31fu;
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return double(h) * 0x1p-32;
}

double valueNoise(const glm::dvec3& p) {
  const glm::dvec3 f = glm::floor(p);
  const glm::ivec3 i(f);
  glm::dvec3 t = p - f;
  t = t * t * (3.0 - 2.0 * t);
  double v = 0.0;
  for (int c = 0; c < 8; ++c) {
    const glm::ivec3 o(c & 1, (c >> 1) & 1, (c >> 2) & 1);
    const double w = (o.x ? t.x : 1.0 - t.x) * (o.y ? t.y : 1.0 - t.y) * (o.z ? t.z : 1.0 - t.z);
    v += w * lattice(i.x + o.x, i.y + o.y, i.z + o.z);
  }
  return v;
}

// Turbulence: four octaves of value noise, in about [0, 1).
double turbulence(const glm::dvec3& p) {
  double sum = 0.0, amplitude = 0.5, frequency = 1.0;
  for (int k = 0; k < 4; ++k) {
    sum += amplitude * valueNoise(p * frequency);
    amplitude *= 0.5;
    frequency *= 2.0;
  }
  return sum / 0.9375;
}

}  // namespace

MediumSample MediumGrid::at(const glm::dvec3& u) const {
  const glm::dvec3 f =
      glm::clamp(u * glm::dvec3(size) - 0.5, glm::dvec3(0.0), glm::dvec3(size - 1));
  const glm::ivec3 i0 = glm::min(glm::ivec3(f), size - 1);
  const glm::ivec3 i1 = glm::min(i0 + 1, size - 1);
  const glm::dvec3 t = f - glm::dvec3(i0);
  MediumSample out;
  for (int c = 0; c < 8; ++c) {
    const glm::ivec3 o(c & 1, (c >> 1) & 1, (c >> 2) & 1);
    const glm::ivec3 i(o.x ? i1.x : i0.x, o.y ? i1.y : i0.y, o.z ? i1.z : i0.z);
    const double w = (o.x ? t.x : 1.0 - t.x) * (o.y ? t.y : 1.0 - t.y) * (o.z ? t.z : 1.0 - t.z);
    const MediumSample& s =
        samples[(size_t(i.z) * size_t(size.y) + size_t(i.y)) * size_t(size.x) + size_t(i.x)];
    out.sigma_a += w * s.sigma_a;
    out.sigma_s_prime += w * s.sigma_s_prime;
    out.g += w * s.g;
  }
  return out;
}

Expected<MediumGrid> readMediumGrid(const std::string& path) {
  PENUMBRA_TRY(checkInputFile(path));
  std::ifstream in(path, std::ios::binary);
  if (!in) return inputError(path, "", "cannot be opened");
  std::string magic, dims;
  if (!std::getline(in, magic) || magic != kMagic) {
    return inputError(path, "line 1", fmt::format("is not a medium grid (expected '{}')", kMagic));
  }
  if (!std::getline(in, dims)) return inputError(path, "line 2", "missing: NX NY NZ");
  std::istringstream ds(dims);
  long long nx = 0, ny = 0, nz = 0;
  std::string rest;
  if (!(ds >> nx >> ny >> nz) || (ds >> rest)) {
    return inputError(path, "line 2", "must be three integers NX NY NZ");
  }
  for (long long n : {nx, ny, nz}) {
    if (n < 1 || n > kMediumGridMaxSide) {
      return inputError(
          path, "line 2",
          fmt::format("{}x{}x{}: each side must be in [1, {}]", nx, ny, nz, kMediumGridMaxSide));
    }
  }
  const size_t count = size_t(nx) * size_t(ny) * size_t(nz);
  const std::streampos start = in.tellg();
  in.seekg(0, std::ios::end);
  const std::streamoff bytes = in.tellg() - start;
  const std::streamoff want = std::streamoff(count * kFloats * sizeof(float));
  if (bytes != want) {
    return inputError(path, "data",
                      fmt::format("{} bytes after the header; {} samples of 7 float32 need {}",
                                  bytes, count, want));
  }
  in.seekg(start);
  std::vector<float> raw(count * kFloats);
  in.read(reinterpret_cast<char*>(raw.data()), want);
  if (!in) return inputError(path, "data", "could not be read");
  if constexpr (std::endian::native == std::endian::big) {
    for (float& f : raw) {
      uint32_t u;
      std::memcpy(&u, &f, 4);
      u = __builtin_bswap32(u);
      std::memcpy(&f, &u, 4);
    }
  }
  MediumGrid g;
  g.size = glm::ivec3(int(nx), int(ny), int(nz));
  g.samples.resize(count);
  for (size_t i = 0; i < count; ++i) {
    const float* r = &raw[i * kFloats];
    const size_t x = i % size_t(nx), y = (i / size_t(nx)) % size_t(ny),
                 z = i / (size_t(nx) * size_t(ny));
    for (int k = 0; k < 6; ++k) {
      if (!std::isfinite(r[k]) || r[k] < 0.0f) {
        return inputError(path, fmt::format("sample ({}, {}, {}) value {}", x, y, z, k),
                          "coefficients must be finite and >= 0");
      }
    }
    if (!(r[6] > -1.0f && r[6] < 1.0f)) {
      return inputError(path, fmt::format("sample ({}, {}, {}) g", x, y, z), "must be in (-1, 1)");
    }
    MediumSample& s = g.samples[i];
    s.sigma_a = glm::dvec3(r[0], r[1], r[2]) * 1e3;  // per mm -> per m
    s.sigma_s_prime = glm::dvec3(r[3], r[4], r[5]) * 1e3;
    s.g = r[6];
  }
  return g;
}

Status writeMediumGrid(const std::string& path, const MediumGrid& grid) {
  std::ostringstream out(std::ios::binary);
  out << kMagic << "\n" << grid.size.x << " " << grid.size.y << " " << grid.size.z << "\n";
  for (const MediumSample& s : grid.samples) {
    const float v[kFloats] = {float(s.sigma_a.x * 1e-3),
                              float(s.sigma_a.y * 1e-3),
                              float(s.sigma_a.z * 1e-3),
                              float(s.sigma_s_prime.x * 1e-3),
                              float(s.sigma_s_prime.y * 1e-3),
                              float(s.sigma_s_prime.z * 1e-3),
                              float(s.g)};
    out.write(reinterpret_cast<const char*>(v), sizeof(v));
  }
  const std::string bytes = out.str();
  return writeAtomically(
      path, [&](const std::string& tmp) -> Status { return writeBytesTo(path, tmp, bytes); });
}

bool isMediumPattern(const std::string& name) {
  return name == "veins" || name == "layers";
}

const char* mediumPatternNames() {
  return "veins, layers";
}

MediumSample mediumAt(const Subsurface& base, const glm::dvec3& u) {
  if (base.grid) return base.grid->at(u);
  MediumSample s{base.sigma_a, base.sigma_s_prime, base.g};
  if (base.pattern == "veins") {
    // Perlin's marble: a sine across the block, bent by turbulence; its zeros are the veins.
    const double v = std::sin(2.0 * std::numbers::pi *
                              (3.0 * u.x + 1.5 * u.y + 2.0 * u.z + 2.5 * turbulence(u * 4.0)));
    const double vein = std::exp(-(v * v) / (0.15 * 0.15));
    s.sigma_a *= 1.0 + 60.0 * vein;
    s.sigma_s_prime *= 1.0 + 0.5 * vein;
  } else if (base.pattern == "layers") {
    // Jade: bands across y, slightly wavy; denser bands absorb more red and blue (greener).
    const double b =
        0.5 + 0.5 * std::sin(2.0 * std::numbers::pi * (6.0 * u.y + 0.4 * turbulence(u * 3.0)));
    s.sigma_a *= glm::dvec3(0.3 + 1.4 * b, 0.3 + 0.7 * b, 0.3 + 1.4 * b);
  }
  return s;
}

}  // namespace penumbra
