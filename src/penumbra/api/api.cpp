// The public API (penumbra.h): each call parses its options with the library's descriptions
// (methods/option_input.h) and runs the library's render or bake (methods/render.h), as the CLI
// does, so that options, checks, defaults and messages are the command line's.
#include "penumbra/penumbra.h"

#include "penumbra/cluster/communicator.h"
#include "penumbra/core/check.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/core/log.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/io/image_io.h"
#include "penumbra/io/ray_file.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/methods/option_input.h"
#include "penumbra/methods/registry.h"
#include "penumbra/methods/render.h"
#include "penumbra/methods/run_context.h"
#include "penumbra/methods/scene_inputs.h"
#include "penumbra/methods/trace.h"
#include "penumbra/scene/scene.h"

#include <fmt/format.h>

#include <cmath>
#include <csignal>
#include <mutex>
#include <new>
#include <optional>

namespace penumbra::api {

namespace {

Error toApiError(const penumbra::Error& e) {
  return Error(e.kind == penumbra::ErrorKind::kInput ? ErrorKind::kInput : ErrorKind::kRuntime,
               e.describe());
}

Image toApiImage(const penumbra::Image& image) {
  Image out;
  out.width = image.width;
  out.height = image.height;
  out.rgb.resize(image.pixels.size() * 3);
  for (size_t i = 0; i < image.pixels.size(); ++i) {
    out.rgb[3 * i] = image.pixels[i].x;
    out.rgb[3 * i + 1] = image.pixels[i].y;
    out.rgb[3 * i + 2] = image.pixels[i].z;
  }
  return out;
}

// One call at a time: a session, the progress observer and the interrupt flag are the process's.
std::mutex& callMutex() {
  static std::mutex m;
  return m;
}

// What a call holds while it runs: the lock, and a stop request made before the call forgotten
// and one made during it kept. render and bake hand the progress callback and the stop to the
// library's run (methods/run_context.h); a call outside it (trace) has its long work stop at a
// request through a progress observer of its own (`observe_stops`).
class CallScope {
 public:
  explicit CallScope(bool observe_stops = false) : lock_(callMutex()) {
    clearInterrupt();
    keepInterruptRequests(true);
    if (observe_stops) {
      observer_.stop_on_interrupt = true;
      setProgressObserver(&observer_);
    }
  }
  ~CallScope() {
    if (observer_.stop_on_interrupt) setProgressObserver(nullptr);
    keepInterruptRequests(false);
  }
  CallScope(const CallScope&) = delete;
  CallScope& operator=(const CallScope&) = delete;

 private:
  std::lock_guard<std::mutex> lock_;
  ProgressObserver observer_;
};

// Runs `work`, turning what it throws into Error.
template <typename Work>
auto guarded(Work&& work) -> decltype(work()) {
  try {
    return work();
  } catch (const Error&) {
    throw;
  } catch (const Interrupted&) {
    throw Error(ErrorKind::kInterrupted, "interrupted");
  } catch (const InternalError& e) {
    throw Error(ErrorKind::kInternal, e.what());
  } catch (const std::bad_alloc&) {
    throw Error(ErrorKind::kRuntime, "out of memory");
  } catch (const std::exception& e) {
    throw Error(ErrorKind::kRuntime, e.what());
  }
}

// The communicator a call with one runs over (cluster/communicator.h), null for this process
// alone.
class OverCommunicator {
 public:
  explicit OverCommunicator(const Communicator* comm) {
    if (!comm || comm->mpi_fortran_handle < 0) return;  // this process alone
    Expected<std::unique_ptr<penumbra::Communicator>> c =
        wrapMpiCommunicator(comm->mpi_fortran_handle);
    if (!c) throw toApiError(c.error());
    comm_ = std::move(*c);
  }
  penumbra::Communicator* get() const { return comm_.get(); }

 private:
  std::unique_ptr<penumbra::Communicator> comm_;
};

// The name a command is given for the scene: what its default file names derive from.
std::string commandSceneName(const penumbra::Scene& scene) {
  const std::string& source = scene.source;
  return source.starts_with("builtin:") ? source.substr(8) : source;
}

// The typed options as the library's named values (methods/option_input.h).
std::vector<NamedValue> namedValues(const Options& options) {
  std::vector<NamedValue> out;
  for (const auto& [name, value] : options.values) {
    out.emplace_back(name, std::visit([](const auto& v) { return nlohmann::json(v); }, value));
  }
  return out;
}

Result toApiResult(RunResult&& run) {
  Result result;
  result.interrupted = run.interrupted;
  for (const penumbra::Image& image : run.images) result.images.push_back(toApiImage(image));
  if (!run.stats.is_null()) result.stats_json = run.stats.dump();
  return result;
}

// Runs render or bake (`run`) on `scene` with the options `parse` gives: the library's call with
// the caller's progress, stop requests, communicator and results kept in memory.
template <typename Options_, typename Parse, typename Run>
Result runCall(const Scene& scene, Parse parse, Run run, const ProgressCallback& progress,
               const Communicator* comm) {
  return guarded([&] {
    const CallScope call;
    const OverCommunicator over(comm);
    Options_ defaults;
    defaults.scene = commandSceneName(scene.internal());
    auto input = parse(std::move(defaults));
    if (!input) throw toApiError(input.error());
    initLogging(input->common.quiet);
    RunContext context;
    context.scene =
        std::shared_ptr<const penumbra::Scene>(std::shared_ptr<void>(), &scene.internal());
    context.given = input->given;
    context.progress = progress;
    context.stop_on_request = true;
    context.keep_results = true;
    context.communicator = over.get();
    Expected<RunResult> result = run(std::move(input->options), input->common, context);
    if (!result) throw toApiError(result.error());
    return toApiResult(std::move(*result));
  });
}

Result renderWith(const Scene& scene, const std::vector<std::string>* words, const Options* typed,
                  const ProgressCallback& progress, const Communicator* comm) {
  return runCall<RenderOptions>(
      scene,
      [&](RenderOptions defaults) {
        return words ? renderInputFromWords(*words, std::move(defaults))
                     : renderInputFromValues(namedValues(*typed), std::move(defaults));
      },
      &renderScene, progress, comm);
}

Result bakeWith(const Scene& scene, const std::vector<std::string>* words, const Options* typed,
                const ProgressCallback& progress, const Communicator* comm) {
  return runCall<BakeOptions>(
      scene,
      [&](BakeOptions defaults) {
        return words ? bakeInputFromWords(*words, std::move(defaults))
                     : bakeInputFromValues(namedValues(*typed), std::move(defaults));
      },
      &bakeScene, progress, comm);
}

}  // namespace

std::string version() {
  return PENUMBRA_VERSION;
}

Error::Error(ErrorKind kind, const std::string& message)
    : std::runtime_error(message), kind_(kind) {}

int Error::exitCode() const {
  switch (kind_) {
    case ErrorKind::kInput:
      return 2;
    case ErrorKind::kInterrupted:
      return kInterruptedExitCode;
    default:
      return 1;
  }
}

Scene::Scene() : impl_(std::make_shared<const penumbra::Scene>()) {}

Scene Scene::load(const std::string& name_or_path) {
  return load(name_or_path, LoadOptions{});
}

Scene Scene::load(const std::string& name_or_path, const LoadOptions& options) {
  return guarded([&] {
    SceneInputOptions in;
    in.allow_outside_files = options.allow_outside_files;
    in.max_texture_size = options.max_texture_size;
    if (options.gltf_scene >= 0) in.gltf_scene = options.gltf_scene;
    if (options.max_texture_size < 1 || options.max_texture_size > 16384) {
      throw Error(ErrorKind::kInput, fmt::format("max_texture_size {} is outside [1, 16384]",
                                                 options.max_texture_size));
    }
    Expected<penumbra::Scene> loaded = loadScene(name_or_path, sceneLoadOptions(in, false));
    if (!loaded) throw toApiError(loaded.error());
    Scene s;
    s.impl_ = std::make_shared<const penumbra::Scene>(std::move(*loaded));
    return s;
  });
}

Scene Scene::fromArrays(std::span<const float> positions, std::span<const uint32_t> indices,
                        std::span<const uint32_t> material_ids, const std::string& description,
                        const std::string& source) {
  return guarded([&] {
    if (positions.size() % 3 != 0) {
      throw Error(ErrorKind::kInput, fmt::format("{}: positions: {} values is not three per vertex",
                                                 source, positions.size()));
    }
    if (indices.size() % 3 != 0) {
      throw Error(ErrorKind::kInput, fmt::format("{}: indices: {} values is not three per triangle",
                                                 source, indices.size()));
    }
    const size_t triangles = indices.size() / 3;
    if (!material_ids.empty() && material_ids.size() != triangles) {
      throw Error(ErrorKind::kInput, fmt::format("{}: material_ids: {} ids for {} triangles",
                                                 source, material_ids.size(), triangles));
    }
    // The mesh joins the description's scene before it is checked as a loaded file is: finite
    // positions, indices and material ids in range, a mesh with some area.
    const auto add_mesh = [&](penumbra::Scene& scene) {
      if (scene.materials.empty()) scene.materials.push_back(Material{.name = "default"});
      if (triangles == 0) return;
      Mesh mesh;
      mesh.name = source;
      mesh.positions.resize(positions.size() / 3);
      for (size_t v = 0; v < mesh.positions.size(); ++v) {
        mesh.positions[v] = {positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]};
      }
      mesh.triangles.resize(triangles);
      mesh.material_ids.resize(triangles, 0);
      for (size_t t = 0; t < triangles; ++t) {
        mesh.triangles[t] = {indices[3 * t], indices[3 * t + 1], indices[3 * t + 2]};
        if (!material_ids.empty()) mesh.material_ids[t] = material_ids[t];
      }
      scene.meshes.push_back(std::move(mesh));
    };
    Expected<penumbra::Scene> parsed =
        parseSceneJson(source, description.empty() ? std::string("{}") : description, add_mesh);
    if (!parsed) throw toApiError(parsed.error());
    penumbra::Scene scene = std::move(*parsed);
    Scene s;
    s.impl_ = std::make_shared<const penumbra::Scene>(std::move(scene));
    return s;
  });
}

const std::string& Scene::source() const {
  return impl_->source;
}
size_t Scene::triangleCount() const {
  return impl_->triangleCount();
}
size_t Scene::vertexCount() const {
  return impl_->vertexCount();
}
size_t Scene::lightCount() const {
  return impl_->lights.size();
}
size_t Scene::materialCount() const {
  return impl_->materials.size();
}
std::vector<std::string> Scene::warnings() const {
  return impl_->warnings;
}

std::vector<float> Scene::flatPositions() const {
  const FlatTriangles flat = flattenScene(*impl_);
  std::vector<float> out(flat.positions.size() * 3);
  for (size_t i = 0; i < flat.positions.size(); ++i) {
    for (int k = 0; k < 3; ++k) out[3 * i + size_t(k)] = flat.positions[i][k];
  }
  return out;
}

std::vector<uint32_t> Scene::flatIndices() const {
  const FlatTriangles flat = flattenScene(*impl_);
  std::vector<uint32_t> out(flat.triangles.size() * 3);
  for (size_t i = 0; i < flat.triangles.size(); ++i) {
    for (int k = 0; k < 3; ++k) out[3 * i + size_t(k)] = flat.triangles[i][k];
  }
  return out;
}

Result render(const Scene& scene, const std::vector<std::string>& options,
              const ProgressCallback& progress) {
  return renderWith(scene, &options, nullptr, progress, nullptr);
}

Result render(const Scene& scene, const Options& options, const ProgressCallback& progress) {
  return renderWith(scene, nullptr, &options, progress, nullptr);
}

Result bake(const Scene& scene, const std::vector<std::string>& options,
            const ProgressCallback& progress) {
  return bakeWith(scene, &options, nullptr, progress, nullptr);
}

Result bake(const Scene& scene, const Options& options, const ProgressCallback& progress) {
  return bakeWith(scene, nullptr, &options, progress, nullptr);
}

std::vector<MethodDescription> methods() {
  std::vector<MethodDescription> out;
  for (const MethodInfo& m : methodInfos()) out.push_back({m.name, m.summary, m.source, m.bakes});
  return out;
}

std::vector<OptionDescription> options(const std::string& command) {
  if (command != "render" && command != "bake") {
    throw Error(ErrorKind::kInput, fmt::format("options of '{}': use render or bake", command));
  }
  static const char* const kKinds[] = {"flag",  "int",    "unsigned", "real",
                                       "reals", "choice", "text"};
  std::vector<OptionDescription> out;
  const auto add = [&](const std::vector<OptionSpec>& specs) {
    for (const OptionSpec& s : specs) {
      if (s.positional) continue;
      OptionDescription& d = out.emplace_back();
      d.name = s.name;
      d.kind = kKinds[int(s.kind)];
      d.help = s.help;
      d.unit = s.unit;
      if (s.range) d.range = s.range->describe();
      d.choices = s.choices;
      for (const OptionUse& u : s.uses) {
        d.methods.push_back({u.method, u.default_value, u.range ? u.range->describe() : ""});
      }
      d.repeatable = s.repeatable;
    }
  };
  add(command == "render" ? renderOptionSpecs() : bakeOptionSpecs());
  add(commonOptionSpecs());
  return out;
}

bool mpiAvailable() {
  return mpiBuilt();
}

Result render(const Communicator& comm, const Scene& scene, const std::vector<std::string>& options,
              const ProgressCallback& progress) {
  return renderWith(scene, &options, nullptr, progress, &comm);
}

Result render(const Communicator& comm, const Scene& scene, const Options& options,
              const ProgressCallback& progress) {
  return renderWith(scene, nullptr, &options, progress, &comm);
}

Result bake(const Communicator& comm, const Scene& scene, const std::vector<std::string>& options,
            const ProgressCallback& progress) {
  return bakeWith(scene, &options, nullptr, progress, &comm);
}

Result bake(const Communicator& comm, const Scene& scene, const Options& options,
            const ProgressCallback& progress) {
  return bakeWith(scene, nullptr, &options, progress, &comm);
}

Hits trace(const Communicator& comm, const Scene& scene, std::span<const float> rays,
           const TraceOptions& options) {
  const OverCommunicator over(&comm);
  std::optional<CommunicatorScope> scope;
  if (over.get()) scope.emplace(*over.get());
  return trace(scene, rays, options);
}

Hits trace(const Scene& scene, std::span<const float> rays, const TraceOptions& options) {
  return guarded([&] {
    const CallScope call(/*observe_stops=*/true);
    if (rays.size() % 8 != 0) {
      throw Error(ErrorKind::kInput,
                  fmt::format("rays: {} values is not eight per ray (ox oy oz tmin dx dy dz tmax)",
                              rays.size()));
    }
    if (options.threads < 0) {
      throw Error(ErrorKind::kInput, fmt::format("threads {} is negative", options.threads));
    }
    // The rays in SoA (32 B), the engine's hits (16 B) and the answers handed back (16 B), before
    // any of it is allocated.
    const size_t count = rays.size() / 8;
    checkMemory(uint64_t(count) * 64, fmt::format("tracing {} rays", count));
    Expected<RayBatch> batch = decodeRays("rays", rays.data(), count);
    if (!batch) throw toApiError(batch.error());
    penumbra::TraceOptions to;
    to.device = options.device;
    to.occlusion = options.occlusion;
    to.t_min = options.t_min;
    to.t_max = options.t_max;
    to.r_min = options.r_min;
    if (options.cache_rays > 0) to.cache_rays = options.cache_rays;
    initLogging(options.quiet);
    const auto thread_limit = limitThreads(options.threads);
    // Over several ranks: rank 0's rays shared out, the answers on rank 0 (methods/trace.h).
    penumbra::Communicator& comm = currentCommunicator();
    if (comm.distributed()) {
      const Status ready = agreeReady(comm, checkTraceOptions(to));
      if (!ready) throw toApiError(ready.error());
    }
    Expected<TraceRun> run = comm.distributed()
                                 ? traceOverRanks(comm, scene.internal(), *batch, to)
                                 : traceScene(scene.internal(), *batch, to, /*dry_run=*/false);
    if (!run) throw toApiError(run.error());
    Hits hits;
    if (!comm.root()) return hits;
    hits.stats_json = run->stats.dump();
    if (options.occlusion) {
      hits.occluded = std::move(run->occluded);
      return hits;
    }
    // As the hit file has them (io/ray_file.h: reportedHit).
    const size_t n = run->hits.size();
    hits.triangle.resize(n);
    hits.t.resize(n);
    hits.u.resize(n);
    hits.v.resize(n);
    for (size_t i = 0; i < n; ++i) {
      const Hit h = reportedHit(run->hits.get(i));
      hits.triangle[i] = h.triangle, hits.t[i] = h.t, hits.u[i] = h.u, hits.v[i] = h.v;
    }
    return hits;
  });
}

void checkMemory(uint64_t bytes, const std::string& what) {
  const Status fits = ::penumbra::checkMemory(bytes, what);
  if (!fits) throw toApiError(fits.error());
}

Image readImage(const std::string& path) {
  return guarded([&] {
    Expected<penumbra::Image> image = penumbra::readImage(path);
    if (!image) throw toApiError(image.error());
    return toApiImage(*image);
  });
}

void writeImage(const std::string& path, const Image& image, const std::string& tonemap,
                double exposure) {
  guarded([&] {
    if (image.width < 1 || image.height < 1 ||
        image.rgb.size() != size_t(image.width) * size_t(image.height) * 3) {
      throw Error(ErrorKind::kInput,
                  fmt::format("{}: the image is {} x {} with {} values (three per pixel needed)",
                              path, image.width, image.height, image.rgb.size()));
    }
    if (tonemap != "reinhard" && tonemap != "exposure") {
      throw Error(ErrorKind::kInput,
                  fmt::format("tonemap '{}': use reinhard or exposure", tonemap));
    }
    if (!std::isfinite(exposure)) {
      throw Error(ErrorKind::kInput, fmt::format("exposure {} is not finite", exposure));
    }
    penumbra::Image linear(image.width, image.height);
    for (size_t i = 0; i < linear.pixels.size(); ++i) {
      linear.pixels[i] = {image.rgb[3 * i], image.rgb[3 * i + 1], image.rgb[3 * i + 2]};
      if (!std::isfinite(linear.pixels[i].x) || !std::isfinite(linear.pixels[i].y) ||
          !std::isfinite(linear.pixels[i].z)) {
        throw Error(ErrorKind::kInput,
                    fmt::format("{}: pixel ({}, {}) is not finite", path, i % size_t(image.width),
                                i / size_t(image.width)));
      }
    }
    ToneMapSettings settings;
    settings.op = tonemap == "exposure" ? ToneMapOperator::kExposure : ToneMapOperator::kReinhard;
    settings.exposure_stops = float(exposure);
    const Status s = penumbra::writeImage(path, linear, settings);
    if (!s) throw toApiError(s.error());
  });
}

void requestInterrupt() {
  penumbra::requestInterrupt(SIGINT);
}

}  // namespace penumbra::api
