// One method running live on a scene that a person edits: what the interactive viewer shows, and
// what a script (or a test) can drive without a window. A session owns the scene and the solver
// of one method, takes changes to the camera, the lights and the materials, and advances its
// work a slice at a time (a frame budget), so that a window can stay responsive while
//
//  - the path tracer accumulates samples (the same image as `render` bit for bit once all of
//    `spp` are in: PathTracer::addSamples);
//  - matrix radiosity solves again after a light or a material changed (dynamic relighting,
//    Carr et al. 2003 sec. 1: the form factors stay);
//  - progressive radiosity shoots (Wallner) and stochastic radiosity averages its iterations
//    (Barsi and Jakab), each slice of shots showing the current solution;
//  - the subsurface methods (dipole links, Carr et al. 2003; light propagation volumes, Børlum
//    et al. 2011) render a frame for the lights as they are.
//
// Every method's solver, options and defaults are the library's, as `penumbra render` uses them:
// anything a session shows, `render` computes headless from the same scene and options.
// Builds (form factors, links, lightmaps) happen in the first advance after a change that needs
// them, in one piece. Runs on the CPU, or with LiveSettings::gpu the GPU twins where `render` has
// them for the method.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/scene/camera.h"
#include "penumbra/scene/scene.h"
#include "penumbra/subsurface/lpv.h"

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra {

enum class LiveMethod { kPathTrace, kMatrix, kProgressive, kStochastic, kSss, kLpv };

inline constexpr LiveMethod kLiveMethods[] = {LiveMethod::kPathTrace,   LiveMethod::kMatrix,
                                              LiveMethod::kProgressive, LiveMethod::kStochastic,
                                              LiveMethod::kSss,         LiveMethod::kLpv};

// The names `render --method` takes.
std::string_view liveMethodName(LiveMethod method);
std::optional<LiveMethod> parseLiveMethod(std::string_view name);
// Whether the method has GPU twins a session runs (LiveSettings::gpu): matrix, sss, lpv.
bool liveMethodHasGpu(LiveMethod method);

struct LiveSettings {
  int width = 512, height = 512;
  // The path tracer's samples per pixel (its image is complete with this many), the other
  // methods' jittered view rays per pixel; 0: each method's `render` default (64 for the path
  // tracer, else 4).
  int spp = 0;
  uint64_t seed = 0;
  // Radiosity: the lightmap texels (progressive, stochastic) or clusters (matrix); 0: the
  // method's default.
  uint32_t elements = 0;
  int iterations = 0;  // the radiosity methods' cap; 0: each method's `render` default
  LpvOptions lpv;
  // The GPU twins, as `render --device gpu` runs them: matrix radiosity's Jacobi solve, the
  // dipole's passes 1 and 2, the light propagation volumes' propagation. Needs the caller's
  // OpenGL 4.5 context current on the calling thread for every advance; the other methods
  // refuse it (create()).
  bool gpu = false;
};

// What the last advance did, for a frame-time graph.
struct LiveStep {
  bool image_changed = false;
  double build_seconds = 0.0;  // solvers (re)built in this step
  double solve_seconds = 0.0;  // samples, shots, iterations, frames
  double view_seconds = 0.0;   // the image of the solution
};

class LiveSession {
 public:
  // Checks the method's requirements of the scene (a translucent material for sss and lpv, an
  // emitter or a light for radiosity) and the settings; builds nothing yet. The scene must have
  // passed validateScene.
  static Expected<LiveSession> create(Scene scene, LiveMethod method, const LiveSettings& settings,
                                      const Camera& camera);
  LiveSession(LiveSession&&) noexcept;
  LiveSession& operator=(LiveSession&&) noexcept;
  ~LiveSession();

  // Changes (each restarts what depends on it; unchanged values cost nothing).
  void setCamera(const Camera& camera);
  void setLights(const std::vector<Light>& lights);
  void setMaterials(const std::vector<Material>& materials);
  // The image size (the path tracer and the views start again).
  void setSize(int width, int height);

  // Works for about `budget_seconds` (at least one unit of work: a row band of samples, a shot,
  // an iteration, a frame); budget <= 0 works until done().
  Expected<LiveStep> advance(double budget_seconds);
  // Nothing left to do for the current state: every sample in, the solve converged or at its
  // cap, the frame rendered.
  bool done() const;

  // Linear radiance (W m^-2 sr^-1), width x height; black before the first advance.
  const Image& image() const;
  // One line on the state of the work ("sample 12 of 64", "iteration 40, residual 3e-5").
  std::string status() const;

  const Scene& scene() const;
  const Camera& camera() const;
  LiveMethod method() const;
  const LiveSettings& settings() const;

 private:
  struct State;
  std::unique_ptr<State> s_;
  LiveSession() = default;
};

}  // namespace penumbra
