// `penumbra rays`: writes a ray file for `penumbra trace` (and for other tracers): the camera's
// primary rays or diffuse rays from random surface points (raytrace/ray_sets.h).
#include "penumbra/accel/bounds.h"
#include "penumbra/app/commands.h"
#include "penumbra/core/file_util.h"
#include "penumbra/core/memory.h"
#include "penumbra/io/ray_file.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/raytrace/ray_sets.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <glm/geometric.hpp>

namespace penumbra {

namespace {

Status rays(const RaysOptions& options, const CommonOptions& common) {
  if (options.kind != "camera" && options.kind != "diffuse") {
    return inputError("", "--kind", fmt::format("'{}': use camera or diffuse", options.kind));
  }
  const bool camera = options.kind == "camera";
  if (camera && options.count) return inputError("", "--count", "applies to --kind diffuse only");
  if (!camera && (options.width || options.height)) {
    return inputError("", "--width/--height", "apply to --kind camera only");
  }
  const int width = options.width.value_or(512), height = options.height.value_or(512);
  const uint64_t count =
      camera ? uint64_t(width) * uint64_t(height) : options.count.value_or(1 << 20);
  PENUMBRA_TRY(checkOutputPath(options.output));
  // The rays (32 B each) and the file's bytes.
  PENUMBRA_TRY(checkMemory(count * 64, fmt::format("{} rays", count)));

  Expected<Scene> scene = loadScene(options.scene);
  if (!scene) return scene.error();
  for (const std::string& w : scene->warnings) spdlog::warn("{}", w);
  if (common.dry_run) return {};

  RayBatch batch;
  if (camera) {
    batch = cameraRaySet(scene->camera ? *scene->camera : defaultCamera(*scene), width, height);
  } else {
    const FlatTriangles flat = flattenScene(*scene);
    Bounds3 bounds;
    for (const glm::vec3& p : flat.positions) bounds.extend(p);
    const float t_min = options.t_min.value_or(1e-4f * glm::length(bounds.hi - bounds.lo));
    batch = diffuseRaySet(flat.positions, flat.triangles, count, options.seed, t_min);
    if (batch.size() == 0) return inputError(scene->source, "", "the scene has no surface area");
    spdlog::info("{} diffuse rays from the surface of {}, tmin {:.3g}", count, scene->source,
                 t_min);
  }
  PENUMBRA_TRY(writeRayFile(options.output, batch));
  spdlog::info("wrote {} rays to {}", batch.size(), options.output);
  return {};
}

}  // namespace

int runRays(const RaysOptions& options, const CommonOptions& common) {
  OutputTransaction transaction;
  Status s = rays(options, common);
  if (s.ok() && common.dry_run) return reportDryRun();
  if (s.ok()) s = transaction.commit();
  return s.ok() ? 0 : reportError(s.error());
}

}  // namespace penumbra
