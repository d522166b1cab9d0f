#include "penumbra/methods/bake_output.h"

#include "penumbra/core/check.h"
#include "penumbra/core/file_util.h"
#include "penumbra/core/memory.h"
#include "penumbra/io/asset_files.h"
#include "penumbra/io/image_io.h"
#include "penumbra/methods/render.h"
#include "penumbra/radiosity/radiosity_surface.h"

#include <glm/geometric.hpp>

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <numbers>

#ifndef PENUMBRA_BUILD_SHARE_DIR
#define PENUMBRA_BUILD_SHARE_DIR ""
#endif

namespace penumbra {

namespace {

namespace fs = std::filesystem;

// Below this reflectance a texel's irradiance is taken from its neighbours (irradianceImage).
constexpr double kMinReflectance = 0.02;

bool isGltfPath(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return ext == ".gltf" || ext == ".glb";
}

}  // namespace

Image irradianceImage(const RadiositySurface& surface, const Image& radiance) {
  const ChartAtlas& atlas = surface.atlas;
  PENUMBRA_CHECK(radiance.width == atlas.width && radiance.height == atlas.height);
  Image e(atlas.width, atlas.height);
  std::vector<uint8_t> known(size_t(atlas.width) * size_t(atlas.height), 0);
  for (size_t i = 0; i < surface.elementCount(); ++i) {
    const glm::dvec3 rho = surface.reflectance[i];
    // A texel that reflects (almost) nothing shows (almost) nothing whatever E is, and E
    // measured through it is noise divided by nothing: it takes its neighbours' E instead.
    if (std::max({rho.x, rho.y, rho.z}) < kMinReflectance) continue;
    const size_t t = atlas.element_texel[i];
    const glm::dvec3 reflected =
        std::numbers::pi * glm::dvec3(radiance.pixels[t]) - surface.emission[i];
    for (int c = 0; c < 3; ++c) {
      e.pixels[t][c] = float(std::max(0.0, reflected[c] / std::max(rho[c], kMinReflectance)));
    }
    known[t] = 1;
  }
  fillChartGaps(atlas, e, known);
  return e;
}

RgbmImage encodeRgbm(const Image& linear) {
  RgbmImage out;
  out.width = linear.width;
  out.height = linear.height;
  float peak = 0.0f;
  for (const glm::vec3& p : linear.pixels) peak = std::max({peak, p.x, p.y, p.z});
  out.scale = peak > 0.0f && std::isfinite(peak) ? double(peak) : 1.0;
  out.rgba.resize(4 * linear.pixels.size());
  for (size_t i = 0; i < linear.pixels.size(); ++i) {
    const glm::dvec3 v = glm::max(glm::dvec3(linear.pixels[i]) / out.scale, glm::dvec3(0.0));
    const double m = std::max({v.x, v.y, v.z});
    // a: the smallest step of 1/255 that holds the largest channel.
    const int a = std::clamp(int(std::ceil(m * 255.0 - 1e-9)), 1, 255);
    const double am = double(a) / 255.0;
    for (int c = 0; c < 3; ++c) {
      out.rgba[4 * i + size_t(c)] = uint8_t(std::clamp(std::lround(v[c] / am * 255.0), 0L, 255L));
    }
    out.rgba[4 * i + 3] = uint8_t(a);
  }
  return out;
}

Image decodeRgbm(const RgbmImage& rgbm) {
  Image img(rgbm.width, rgbm.height);
  for (size_t i = 0; i < img.pixels.size(); ++i) {
    const double a = rgbm.rgba[4 * i + 3] / 255.0;
    for (int c = 0; c < 3; ++c) {
      img.pixels[i][c] = float(rgbm.scale * (rgbm.rgba[4 * i + size_t(c)] / 255.0) * a);
    }
  }
  return img;
}

std::vector<TriangleLightmapUvs> triangleLightmapUvs(const Scene& scene,
                                                     std::span<const SurfaceFace> faces,
                                                     std::span<const glm::vec2> uvs,
                                                     const Image& irradiance) {
  PENUMBRA_CHECK(uvs.size() == 3 * faces.size());
  size_t triangles = 0;
  for (const Mesh& m : scene.meshes) triangles += m.triangles.size();
  std::vector<int64_t> face_of(2 * triangles, -1);
  for (size_t f = 0; f < faces.size(); ++f) {
    face_of[2 * size_t(faces[f].triangle) + (faces[f].back ? 1 : 0)] = int64_t(f);
  }
  // Light a face received: irradiance at its UV centroid times its area.
  auto received = [&](int64_t f, const Mesh& m, uint32_t t) {
    if (f < 0) return 0.0;
    const glm::vec2 c =
        (uvs[3 * size_t(f)] + uvs[3 * size_t(f) + 1] + uvs[3 * size_t(f) + 2]) / 3.0f;
    const int x = std::clamp(int(c.x * float(irradiance.width)), 0, irradiance.width - 1);
    const int y = std::clamp(int(c.y * float(irradiance.height)), 0, irradiance.height - 1);
    const glm::uvec3 tri = m.triangles[t];
    const double area = 0.5 * glm::length(glm::cross(m.positions[tri.y] - m.positions[tri.x],
                                                     m.positions[tri.z] - m.positions[tri.x]));
    return double(luminance(irradiance.at(x, y))) * area;
  };
  std::vector<TriangleLightmapUvs> out(triangles);
  size_t first = 0;
  for (const Mesh& m : scene.meshes) {
    double front = 0.0, back = 0.0;
    for (uint32_t t = 0; t < m.triangles.size(); ++t) {
      front += received(face_of[2 * (first + t)], m, t);
      back += received(face_of[2 * (first + t) + 1], m, t);
    }
    const int side = back > front ? 1 : 0;
    for (uint32_t t = 0; t < m.triangles.size(); ++t) {
      int64_t f = face_of[2 * (first + t) + size_t(side)];
      if (f < 0) f = face_of[2 * (first + t) + size_t(1 - side)];
      if (f < 0) continue;  // degenerate: no texels
      for (int k = 0; k < 3; ++k) out[first + t].uv[k] = uvs[3 * size_t(f) + size_t(k)];
    }
    first += m.triangles.size();
  }
  return out;
}

Status writeAssetBake(const Scene& scene, const Image& irradiance,
                      std::span<const TriangleLightmapUvs> uvs, const nlohmann::json& extras,
                      const AssetBakeFiles& files) {
  std::vector<GltfTriangleSource> sources;
  GltfDocument doc;
  if (isGltfPath(scene.source)) sources = gltfTriangleSources(scene);
  if (!sources.empty()) {
    // The file is read again and its buffers held twice while the new one is assembled.
    std::error_code ec;
    const uintmax_t bytes = fs::file_size(scene.source, ec);
    if (!ec) {
      PENUMBRA_TRY(checkMemory(3 * uint64_t(bytes),
                               fmt::format("{}: writing the baked asset", scene.source)));
    }
    Expected<GltfDocument> read = readGltfDocument(scene.source, files.policy);
    if (!read) return read.error();
    doc = std::move(*read);
  } else {
    doc = documentFromScene(scene, sources);
  }
  PENUMBRA_CHECK(sources.size() == uvs.size());
  const RgbmImage rgbm = encodeRgbm(irradiance);
  PENUMBRA_TRY(writeMethodImage(files.exr, irradiance));
  PENUMBRA_TRY(writePng8(files.png, rgbm.width, rgbm.height, rgbm.rgba, 4));
  LightmapReference lm;
  lm.png_uri = fs::path(files.png).filename().string();
  lm.exr_uri = fs::path(files.exr).filename().string();
  lm.scale = rgbm.scale;
  lm.width = irradiance.width;
  lm.height = irradiance.height;
  return writeLightmappedGltf(std::move(doc), sources, uvs, lm, extras, files.gltf,
                              fs::path(files.bin).filename().string());
}

Expected<std::string> webViewerDirectory() {
  std::vector<std::string> tried;
  auto holds = [&](const fs::path& dir) {
    tried.push_back(dir.string());
    std::error_code ec;
    return fs::is_regular_file(dir / "index.html", ec);
  };
  if (const char* env = std::getenv("PENUMBRA_WEB_DIR"); env && *env) {
    if (holds(env)) return std::string(env);
  }
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path dir = exe.parent_path().parent_path() / "share" / "penumbra" / "web";
    if (holds(dir)) return dir.string();
  }
  if (*PENUMBRA_BUILD_SHARE_DIR) {
    const fs::path dir = fs::path(PENUMBRA_BUILD_SHARE_DIR) / "web";
    if (holds(dir)) return dir.string();
  }
  std::string where;
  for (const std::string& t : tried) where += (where.empty() ? "" : ", ") + t;
  return inputError("", "--web",
                    fmt::format("the web viewer's files are not installed (looked in {}); build "
                                "the project after scripts/install-deps.sh, or set "
                                "PENUMBRA_WEB_DIR",
                                where));
}

// Copies `from` to `to` through the run's transaction.
Status copyOutput(const std::string& from, const std::string& to) {
  Expected<std::string> bytes = readFile(from);
  if (!bytes) return bytes.error();
  return writeAtomically(to, [&](const std::string& tmp) { return writeBytesTo(to, tmp, *bytes); });
}

Status writeWebViewer(const std::string& dir, const std::vector<std::string>& bake_files) {
  Expected<std::string> source = webViewerDirectory();
  if (!source) return source.error();
  OutputTransaction& transaction = *OutputTransaction::current();
  PENUMBRA_TRY(transaction.createDirectories(dir));
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(*source, ec);
       !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (!it->is_regular_file()) continue;
    const fs::path rel = fs::relative(it->path(), *source);
    const fs::path target = fs::path(dir) / rel;
    PENUMBRA_TRY(transaction.createDirectories(target.parent_path().string()));
    PENUMBRA_TRY(copyOutput(it->path().string(), target.string()));
  }
  if (ec)
    return runtimeError(*source, fmt::format("cannot list the viewer's files: {}", ec.message()));
  const fs::path bake_dir = fs::absolute(fs::path(bake_files.front()).parent_path());
  if (bake_dir.lexically_normal() != fs::absolute(dir).lexically_normal()) {
    // The bake's outputs are not yet in place (the transaction places them at its end): copied
    // from what was written.
    for (const std::string& f : bake_files) {
      const OutputTransaction* t = OutputTransaction::current();
      const std::string written = t ? t->pendingTemporary(f) : f;
      PENUMBRA_TRY(copyOutput(written.empty() ? f : written,
                              (fs::path(dir) / fs::path(f).filename()).string()));
    }
  }
  const std::string name = fs::path(bake_files.front()).filename().string();
  const std::string manifest = nlohmann::json{{"gltf", percentEncodePath(name)}}.dump(2) + "\n";
  const std::string path = (fs::path(dir) / "bake.json").string();
  return writeAtomically(path,
                         [&](const std::string& tmp) { return writeBytesTo(path, tmp, manifest); });
}

}  // namespace penumbra
