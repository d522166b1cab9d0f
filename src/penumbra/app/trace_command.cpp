// `penumbra trace`: the Ray Engine as a service (design doc sec. 4).
#include "penumbra/app/commands.h"
#include "penumbra/app/stats_file.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/io/ray_file.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/raytrace/ray_engine.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <filesystem>

namespace penumbra {

namespace {

Status trace(const TraceOptions& options) {
  if (options.device == "gpu") {
    return inputError("", "", "--device gpu: the GPU back end is not available yet; use cpu");
  }
  if (options.device != "cpu" && options.device != "auto") {
    return inputError("", "", fmt::format("--device '{}': use cpu, gpu or auto", options.device));
  }
  PENUMBRA_TRY(checkOutputPath(options.output));
  if (!options.stats.empty()) PENUMBRA_TRY(checkOutputPath(options.stats));
  std::error_code ec;
  const auto ray_bytes = std::filesystem::file_size(options.rays, ec);
  if (!ec) {
    // Rays in SoA (32 B), hits (16 B), the file bytes and the output buffer (16 B).
    PENUMBRA_TRY(
        checkMemory(uint64_t(ray_bytes) / 32 * 96, fmt::format("tracing {} rays", ray_bytes / 32)));
  }

  Expected<Scene> scene = loadScene(options.mesh);
  if (!scene) return scene.error();
  for (const std::string& w : scene->warnings) spdlog::warn("{}", w);
  Expected<RayBatch> rays = readRayFile(options.rays);
  if (!rays) return rays.error();

  std::vector<glm::vec3> positions;
  std::vector<glm::uvec3> triangles;
  for (const Mesh& m : scene->meshes) {
    const uint32_t base = uint32_t(positions.size());
    positions.insert(positions.end(), m.positions.begin(), m.positions.end());
    for (const glm::uvec3& t : m.triangles) triangles.push_back(t + glm::uvec3(base));
  }
  Timer build_timer;
  const RayEngine engine = RayEngine::build(positions, triangles);
  const double build_seconds = build_timer.seconds();

  HitBatch hits;
  Timer trace_timer;
  engine.intersect(*rays, hits);
  const double trace_seconds = trace_timer.seconds();

  PENUMBRA_TRY(writeHitFile(options.output, hits));
  size_t hit_count = 0;
  for (int32_t t : hits.triangle) hit_count += t >= 0;
  const double mrays = trace_seconds > 0.0 ? double(rays->size()) / trace_seconds * 1e-6 : 0.0;
  spdlog::info(
      "{} rays against {} triangles: {} hits; build {:.3f} s, trace {:.3f} s "
      "({:.2f} Mrays/s)",
      rays->size(), triangles.size(), hit_count, build_seconds, trace_seconds, mrays);
  if (!options.stats.empty()) {
    nlohmann::json j = {{"method", "trace"},
                        {"device", "cpu"},
                        {"seconds", build_seconds + trace_seconds},
                        {"build_seconds", build_seconds},
                        {"trace_seconds", trace_seconds},
                        {"rays", rays->size()},
                        {"hits", hit_count},
                        {"triangles", triangles.size()},
                        {"threads", threadCount()},
                        {"bvh_nodes", engine.bvh().nodes.size()},
                        {"bvh_bytes", engine.memoryBytes()},
                        {"mrays_per_s", mrays}};
    PENUMBRA_TRY(writeStatsFile(options.stats, j));
  }
  return {};
}

}  // namespace

int runTrace(const TraceOptions& options, const CommonOptions&) {
  const Status s = trace(options);
  return s.ok() ? 0 : reportError(s.error());
}

}  // namespace penumbra
