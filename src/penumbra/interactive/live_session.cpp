#include "penumbra/interactive/live_session.h"

#include "penumbra/core/memory.h"
#include "penumbra/core/timer.h"
#include "penumbra/interactive/live_settings.h"
#include "penumbra/radiosity/matrix_radiosity.h"
#include "penumbra/radiosity/progressive.h"
#include "penumbra/radiosity/radiosity_solvers.h"
#include "penumbra/radiosity/stochastic.h"
#include "penumbra/raytrace/path_tracer.h"
#include "penumbra/render/lightmap_view.h"
#include "penumbra/render/sss_frames.h"
#include "penumbra/subsurface/sss.h"
#include "penumbra/subsurface/sss_cache.h"

#include <fmt/format.h>

#include <algorithm>
#include <utility>

namespace penumbra {

namespace {

// `render`'s defaults, from where the library states them: the iteration cap of the radiosity
// methods and the matrix solve's tolerance (SolveOptions), the path tracer's samples
// (PathTracerSettings) and the other views' rays per pixel (LightmapViewSettings).
const int kDefaultIterations = SolveOptions{}.max_iterations;
const double kMatrixTolerance = SolveOptions{}.tolerance;
const int kPathTracerSpp = PathTracerSettings{}.spp;
const int kViewSpp = LightmapViewSettings{}.spp;
// A solution's view is drawn again at most this often while the solve goes on (and when it
// ends): the view's rays cost more than a slice of shots. The path tracer's preview (its sums,
// tone-mapped by the window) more often.
constexpr double kViewInterval = 0.25;
constexpr double kPreviewInterval = 0.1;

bool anyTranslucent(const Scene& scene) {
  return std::any_of(scene.materials.begin(), scene.materials.end(),
                     [](const Material& m) { return m.isTranslucent(); });
}

bool sameCamera(const Camera& a, const Camera& b) {
  return a.position == b.position && a.look_at == b.look_at && a.up == b.up &&
         a.vertical_fov == b.vertical_fov;
}

}  // namespace

std::string_view liveMethodName(LiveMethod method) {
  switch (method) {
    case LiveMethod::kPathTrace:
      return "pathtrace";
    case LiveMethod::kMatrix:
      return "matrix";
    case LiveMethod::kProgressive:
      return "progressive";
    case LiveMethod::kStochastic:
      return "stochastic";
    case LiveMethod::kSss:
      return "sss";
    case LiveMethod::kLpv:
      return "lpv";
  }
  return "pathtrace";
}

bool liveMethodHasGpu(LiveMethod method) {
  return method == LiveMethod::kMatrix || method == LiveMethod::kSss || method == LiveMethod::kLpv;
}

std::optional<LiveMethod> parseLiveMethod(std::string_view name) {
  for (LiveMethod m : kLiveMethods) {
    if (liveMethodName(m) == name) return m;
  }
  return std::nullopt;
}

struct LiveSession::State {
  Scene scene;
  Camera camera;
  LiveMethod method = LiveMethod::kPathTrace;
  LiveSettings settings;
  Image image;
  // What a change left to do: build the solver again, solve again, draw the view again.
  bool build = true, solve = true, view = true;
  double last_view = -1.0;  // the session clock when the view was last drawn
  Timer clock;
  std::string status = "not started";

  // Path tracer: the sums of the samples so far; `sample` is in progress over rows < `row`.
  std::unique_ptr<PathTracer> tracer;
  std::vector<glm::dvec3> sum;
  int sample = 0, row = 0, band = 8;
  // Radiosity.
  std::optional<MatrixRadiosity> matrix;
  std::unique_ptr<MatrixRadiositySolver>
      matrix_solver;  // on the CPU or the GPU (LiveSettings::gpu)
  // The lights or the materials changed: the direct term and the system's emission and
  // reflectance are set again (and uploaded) before the next iterations.
  bool relight = false;
  int matrix_iterations = 0;  // of the current solve (since the last build or relighting)
  int matrix_chunk = 1;       // iterations per solve call, sized to the budget
  double matrix_residual = 0.0;
  bool matrix_converged = false;
  std::optional<ProgressiveRadiosity> progressive;
  std::optional<StochasticRadiosity> stochastic;
  // The radiosity methods' view: the camera's hits, kept while the camera and the surface stay.
  std::optional<LightmapView> lightmap_view;
  // The textures' detail the view shows (made with the view: materials change it).
  std::shared_ptr<const LightmapDetail> lightmap_detail;
  // Subsurface. The frames hold a pointer to the solver: both on the heap.
  std::unique_ptr<SssSolver> sss;
  std::unique_ptr<SssFrames> sss_frames;
  std::optional<LpvSolver> lpv;

  int spp() const {
    if (settings.spp > 0) return settings.spp;
    return method == LiveMethod::kPathTrace ? kPathTracerSpp : kViewSpp;
  }
  int iterations() const {
    if (settings.iterations > 0) return settings.iterations;
    // Each method's own default, as `render` has it.
    return method == LiveMethod::kStochastic ? StochasticOptions{}.iterations : kDefaultIterations;
  }
  void restartSamples() {
    sum.assign(size_t(settings.width) * size_t(settings.height), glm::dvec3(0.0));
    sample = 0;
    row = 0;
  }
  LightmapViewSettings viewSettings() const {
    return LightmapViewSettings{settings.width, settings.height, spp(), settings.seed};
  }

  Status buildSolver(LiveStep& step);
  Expected<bool> solveSome(double budget, bool all);
  Status drawView();
  bool solved() const;
};

LiveSession::LiveSession(LiveSession&&) noexcept = default;
LiveSession& LiveSession::operator=(LiveSession&&) noexcept = default;
LiveSession::~LiveSession() = default;

Expected<LiveSession> LiveSession::create(Scene scene, LiveMethod method, const LiveSettings& given,
                                          const Camera& camera) {
  if (given.width < 1 || given.width > (1 << 14) || given.height < 1 || given.height > (1 << 14)) {
    return inputError("", "--width/--height", "must be in [1, 16384]");
  }
  // The method's options checked by their descriptions, as `render` checks them, and the scene's
  // settings for those the caller left to the method (interactive/live_settings.h).
  Expected<LiveSettings> resolved = resolveLiveSettings(scene, method, given);
  if (!resolved) return resolved.error();
  const LiveSettings& settings = *resolved;
  const bool subsurface = method == LiveMethod::kSss || method == LiveMethod::kLpv;
  if (settings.gpu && !liveMethodHasGpu(method)) {
    return inputError(
        "", "--device",
        fmt::format("gpu: --method {} runs on the cpu in the viewer", liveMethodName(method)));
  }
  if (subsurface && !anyTranslucent(scene)) {
    return inputError(scene.source, "",
                      fmt::format("no translucent material (a `subsurface` block) for {}",
                                  liveMethodName(method)));
  }
  if (method == LiveMethod::kLpv) {
    // The options' checks, before any work.
    Expected<LpvSolver> check = LpvSolver::build(scene, settings.lpv);
    if (!check) return check.error();
  }
  LiveSession session;
  session.s_ = std::make_unique<State>();
  State& s = *session.s_;
  s.scene = std::move(scene);
  s.camera = camera;
  s.method = method;
  s.settings = settings;
  s.image = Image(settings.width, settings.height);
  s.restartSamples();
  return session;
}

void LiveSession::setCamera(const Camera& camera) {
  State& s = *s_;
  if (sameCamera(camera, s.camera)) return;
  s.camera = camera;
  s.view = true;
  s.lightmap_view.reset();
  if (s.method == LiveMethod::kPathTrace) {
    s.restartSamples();
    s.solve = true;
  }
  // The dipole's view keeps the camera's hits: made again for the new camera.
  s.sss_frames.reset();
}

void LiveSession::setLights(const std::vector<Light>& lights) {
  State& s = *s_;
  s.scene.lights = lights;
  s.solve = s.view = true;
  switch (s.method) {
    case LiveMethod::kPathTrace:
      // The geometry (and its BVH) stays.
      if (s.tracer) {
        s.tracer->setLights(s.scene.lights);
        s.restartSamples();
      }
      break;
    case LiveMethod::kProgressive:
    case LiveMethod::kStochastic:
      s.build = true;
      break;
    case LiveMethod::kMatrix:
      // Dynamic relighting (in the next advance): the lights' direct term again, the form
      // factors stay.
      s.relight = true;
      break;
    case LiveMethod::kSss:
    case LiveMethod::kLpv:
      break;  // a frame takes the lights as they are
  }
}

void LiveSession::setMaterials(const std::vector<Material>& materials) {
  State& s = *s_;
  s.scene.materials = materials;
  s.solve = s.view = true;
  s.lightmap_view.reset();  // its texture detail follows the materials
  if (s.method == LiveMethod::kMatrix) {
    // Dynamic relighting: new reflectances and emissions, the form factors stay.
    s.relight = true;
    return;
  }
  s.build = true;
}

void LiveSession::setSize(int width, int height) {
  State& s = *s_;
  if (width == s.settings.width && height == s.settings.height) return;
  s.settings.width = std::clamp(width, 1, 1 << 14);
  s.settings.height = std::clamp(height, 1, 1 << 14);
  s.image = Image(s.settings.width, s.settings.height);
  s.restartSamples();
  s.sss_frames.reset();
  s.lightmap_view.reset();
  s.solve = s.view = true;
}

Status LiveSession::State::buildSolver(LiveStep& step) {
  const Timer timer;
  const uint32_t elements = settings.elements;
  lightmap_view.reset();  // it refers to the old surface
  switch (method) {
    case LiveMethod::kPathTrace:
      tracer = std::make_unique<PathTracer>(scene);
      restartSamples();
      break;
    case LiveMethod::kMatrix: {
      MatrixRadiosityOptions mo;
      if (elements > 0) mo.elements = elements;
      mo.form_factors.seed = settings.seed;
      PENUMBRA_TRY(checkMatrixRadiosity(scene, mo));
      Expected<MatrixRadiosity> built = buildMatrixRadiosity(scene, mo);
      if (!built) return built.error();
      matrix.emplace(std::move(*built));
      matrix_iterations = 0;
      matrix_converged = false;
      relight = false;
      matrix_solver.reset();
      Expected<std::unique_ptr<MatrixRadiositySolver>> solver = MatrixRadiositySolver::create(
          *matrix, settings.gpu ? SolverDevice::kGpu : SolverDevice::kCpu);
      if (!solver) return solver.error();
      matrix_solver = std::move(*solver);
      break;
    }
    case LiveMethod::kProgressive: {
      ProgressiveOptions po;
      po.max_iterations = iterations();
      po.atlas.texel_density =
          progressiveTexelDensity(scene, elements > 0 ? elements : kProgressiveDefaultElements);
      Expected<ProgressiveRadiosity> built = ProgressiveRadiosity::build(scene, po);
      if (!built) return built.error();
      progressive.emplace(std::move(*built));
      break;
    }
    case LiveMethod::kStochastic: {
      StochasticOptions so;
      so.iterations = iterations();
      so.seed = settings.seed;
      LightmapResolution r;
      if (elements > 0) r.elements = elements;
      Expected<ChartAtlasOptions> atlas = lightmapAtlasOptions(scene, r);
      if (!atlas) return atlas.error();
      so.atlas = *atlas;
      Expected<StochasticRadiosity> built = StochasticRadiosity::build(scene, so);
      if (!built) return built.error();
      stochastic.emplace(std::move(*built));
      break;
    }
    case LiveMethod::kSss: {
      SssOptions so;
      so.cache_directory = defaultCacheDirectory();
      sss_frames.reset();
      Expected<SssSolver> built = SssSolver::build(scene, so);
      if (!built) return built.error();
      sss = std::make_unique<SssSolver>(std::move(*built));
      break;
    }
    case LiveMethod::kLpv: {
      Expected<LpvSolver> built = LpvSolver::build(scene, settings.lpv);
      if (!built) return built.error();
      lpv.emplace(std::move(*built));
      if (settings.gpu) PENUMBRA_TRY(lpv->useGpu());
      break;
    }
  }
  build = false;
  solve = view = true;
  step.build_seconds += timer.seconds();
  return {};
}

bool LiveSession::State::solved() const {
  switch (method) {
    case LiveMethod::kPathTrace:
      return sample >= spp();
    case LiveMethod::kMatrix:
      return !relight && (matrix_converged || matrix_iterations >= iterations());
    case LiveMethod::kProgressive:
      return progressive->iterations() >= iterations() ||
             progressive->selectShooter() == ProgressiveRadiosity::kNoShooter ||
             (progressive->lightsShot() &&
              progressive->unshotFraction() <= progressive->options().convergence);
    case LiveMethod::kStochastic:
      return stochastic->iterations() >= iterations();
    case LiveMethod::kSss:
    case LiveMethod::kLpv:
      return !solve;
  }
  return true;
}

// Works until the budget is spent (or, with `all`, until solved); true when the solution changed.
Expected<bool> LiveSession::State::solveSome(double budget, bool all) {
  const Timer timer;
  bool changed = false;
  auto more = [&] { return !solved() && (all || timer.seconds() < budget); };
  switch (method) {
    case LiveMethod::kPathTrace: {
      PathTracerSettings pt;
      pt.width = settings.width;
      pt.height = settings.height;
      pt.spp = spp();
      pt.seed = settings.seed;
      while (more()) {
        const Timer band_timer;
        const int y1 = std::min(row + band, settings.height);
        tracer->addSamples(camera, pt, sample, row, y1, sum);
        row = y1;
        if (row >= settings.height) {
          row = 0;
          ++sample;
        }
        // Bands of about a twentieth of the budget.
        const double seconds = band_timer.seconds();
        if (budget > 0.0 && seconds < budget / 40.0) band = std::min(band * 2, settings.height);
        if (budget > 0.0 && seconds > budget / 10.0) band = std::max(band / 2, 1);
        changed = true;
      }
      status = fmt::format("sample {} of {}", std::min(sample + (row > 0 ? 1 : 0), spp()), spp());
      break;
    }
    case LiveMethod::kMatrix: {
      if (relight) {
        matrix->setLights(scene.lights);
        matrix->applyMaterials(scene.materials);
        PENUMBRA_TRY(matrix_solver->relight());
        relight = false;
        matrix_iterations = 0;
        matrix_converged = false;
      }
      while (more()) {
        // As `render`: Gauss-Seidel on the CPU, Jacobi on the GPU, from the last solution. A
        // call ends with the residual of its result (one more product with the matrix), so the
        // calls take as many iterations as fit in about a quarter of the budget.
        const Timer chunk_timer;
        SolveOptions so;
        so.max_iterations = all ? iterations() - matrix_iterations
                                : std::min(matrix_chunk, iterations() - matrix_iterations);
        so.tolerance = kMatrixTolerance;
        so.solver = *matrixSolverFor(matrix_solver->device());
        Expected<SolveStats> solved = matrix_solver->solve(so);
        if (!solved) return solved.error();
        const SolveStats& st = *solved;
        matrix_iterations += st.iterations;
        matrix_residual = st.residual;
        matrix_converged = st.converged;
        changed = true;
        const double seconds = chunk_timer.seconds();
        if (budget > 0.0 && seconds < budget / 8.0) matrix_chunk = std::min(matrix_chunk * 2, 64);
        if (budget > 0.0 && seconds > budget / 2.0) matrix_chunk = std::max(matrix_chunk / 2, 1);
      }
      status =
          fmt::format("{} clusters, iteration {}, residual {:.3g}{}", matrix->size(),
                      matrix_iterations, matrix_residual, matrix_converged ? " (converged)" : "");
      break;
    }
    case LiveMethod::kProgressive: {
      while (more()) {
        progressive->step();
        changed = true;
      }
      status =
          fmt::format("{} texels, shot {}, {:.3g} of the power unshot", progressive->elementCount(),
                      progressive->iterations(), progressive->unshotFraction());
      break;
    }
    case LiveMethod::kStochastic: {
      while (more()) {
        stochastic->step();
        changed = true;
      }
      status =
          fmt::format("{} texels, iteration {} of {}, error {:.3g}", stochastic->elementCount(),
                      stochastic->iterations(), iterations(), stochastic->errorEstimate());
      break;
    }
    case LiveMethod::kSss:
    case LiveMethod::kLpv:
      // A frame is the view: drawn by drawView.
      changed = solve;
      break;
  }
  return changed;
}

Status LiveSession::State::drawView() {
  switch (method) {
    case LiveMethod::kPathTrace: {
      image = Image(settings.width, settings.height);
      for (int y = 0; y < settings.height; ++y) {
        const int count = sample + (y < row ? 1 : 0);
        if (count == 0) continue;
        for (int x = 0; x < settings.width; ++x) {
          const size_t i = size_t(y) * size_t(settings.width) + size_t(x);
          image.pixels[i] = glm::vec3(sum[i] / double(count));
        }
      }
      break;
    }
    case LiveMethod::kMatrix:
    case LiveMethod::kProgressive:
    case LiveMethod::kStochastic: {
      const RadiositySurface& surface = method == LiveMethod::kMatrix ? matrix->surface
                                        : method == LiveMethod::kProgressive
                                            ? progressive->surface()
                                            : stochastic->surface();
      // The camera's hits are kept when they fit in memory; else traced for every view.
      const uint64_t hit_bytes = uint64_t(settings.width) * uint64_t(settings.height) *
                                 uint64_t(spp()) * kLightmapViewBytesPerSample;
      if (!lightmap_view) lightmap_detail = surface.lightmapDetail();
      if (!lightmap_view && checkMemory(hit_bytes, "the view's hits").ok()) {
        lightmap_view.emplace(surface.flat.positions, surface.flat.triangles, surface.atlas, camera,
                              viewSettings(), lightmap_detail.get());
      }
      // As `render` shows each method's solution (methods/render_matrix.cpp,
      // methods/progressive_run.cpp, methods/stochastic_run.cpp).
      const Image lightmap = method == LiveMethod::kMatrix ? matrix->radianceImage(true)
                             : method == LiveMethod::kProgressive
                                 ? progressive->radianceImage(false)
                                 : stochastic->radianceImage();
      image = lightmap_view ? lightmap_view->render(lightmap)
                            : renderLightmapView(surface.flat.positions, surface.flat.triangles,
                                                 surface.atlas, lightmap, camera, viewSettings(),
                                                 lightmap_detail.get());
      break;
    }
    case LiveMethod::kSss: {
      if (!sss_frames) {
        const SssViewSettings frame_view{settings.width, settings.height, spp(), settings.seed};
        Expected<SssFrames> frames = SssFrames::create(*sss, camera, frame_view, settings.gpu);
        if (!frames) return frames.error();
        sss_frames = std::make_unique<SssFrames>(std::move(*frames));
      }
      Expected<SssFrame> frame = sss_frames->render(scene.lights);
      if (!frame) return frame.error();
      image = std::move(frame->image);
      status = fmt::format("{} texels, {} links each", sss->surface().elementCount(),
                           sss->links().per_element);
      solve = false;
      break;
    }
    case LiveMethod::kLpv: {
      Expected<LpvFrameTimes> t = lpv->update(scene);
      if (!t) return t.error();
      image = lpv->render(scene, camera, settings.width, settings.height, spp(), settings.seed);
      const LpvGrid& g = lpv->objects().front().grid;
      status = fmt::format(
          "{}x{}x{} cells, {} steps; voxelise {:.1f}, inject {:.1f}, propagate "
          "{:.1f} ms",
          g.size.x, g.size.y, g.size.z, settings.lpv.steps, 1e3 * t->voxelise, 1e3 * t->inject,
          1e3 * t->propagate);
      solve = false;
      break;
    }
  }
  view = false;
  last_view = clock.seconds();
  return {};
}

Expected<LiveStep> LiveSession::advance(double budget_seconds) {
  State& s = *s_;
  LiveStep step;
  const bool all = !(budget_seconds > 0.0);
  if (s.build) {
    s.status = "building";
    PENUMBRA_TRY(s.buildSolver(step));
  }
  const Timer solve_timer;
  Expected<bool> changed = s.solveSome(budget_seconds - step.build_seconds, all);
  if (!changed) return changed.error();
  if (s.method != LiveMethod::kSss && s.method != LiveMethod::kLpv) s.solve = false;
  step.solve_seconds = solve_timer.seconds();
  if (*changed) s.view = true;
  // A subsurface frame is its view; the others' images are drawn when the work is done, and
  // while it goes on at most every kPreviewInterval (the path tracer's sums, which the window
  // tone-maps and uploads) or kViewInterval (a solution's view: rays).
  const bool finished = s.solved();
  const bool frame = s.method == LiveMethod::kSss || s.method == LiveMethod::kLpv;
  const double interval = s.method == LiveMethod::kPathTrace ? kPreviewInterval : kViewInterval;
  if (s.view &&
      (frame || finished || s.last_view < 0.0 || s.clock.seconds() - s.last_view >= interval)) {
    const Timer view_timer;
    PENUMBRA_TRY(s.drawView());
    step.view_seconds = view_timer.seconds();
    step.image_changed = true;
  }
  return step;
}

bool LiveSession::done() const {
  return !s_->build && !s_->view && s_->solved();
}

const Image& LiveSession::image() const {
  return s_->image;
}
std::string LiveSession::status() const {
  return s_->status;
}
const Scene& LiveSession::scene() const {
  return s_->scene;
}
const Camera& LiveSession::camera() const {
  return s_->camera;
}
LiveMethod LiveSession::method() const {
  return s_->method;
}
const LiveSettings& LiveSession::settings() const {
  return s_->settings;
}

}  // namespace penumbra
