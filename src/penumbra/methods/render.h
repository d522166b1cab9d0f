// `render` and `bake` as library calls (docs/architecture.md): a method's run over a scene and a
// run context (methods/run_context.h). The CLI, the public API (penumbra.h), Python and MPI jobs
// call these; none of them decides how a method runs.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/methods/command_options.h"
#include "penumbra/methods/run_context.h"

#include <string>
#include <vector>

namespace penumbra {

// Runs options.method on context.scene: the scene's settings fill in the options not in
// context.given, every option is checked against its description and the method that takes it,
// the outputs the options name are written together at the end (or none is), and with
// common.dry_run everything is checked (inputs, output paths, the memory the plan needs) and
// nothing is done. An error says what was wrong and where; nothing is left behind.
Expected<RunResult> renderScene(RenderOptions options, const CommonOptions& common,
                                const RunContext& context);
// The same for `bake`: the solution's files in options.output (a directory); the lightmap atlas
// is the result's image.
Expected<RunResult> bakeScene(BakeOptions options, const CommonOptions& common,
                              const RunContext& context);

// The methods behind renderScene (methods/render_*.cpp), run inside its RunScope.
Status renderPathTrace(const RenderOptions& options, const CommonOptions& common);
Status renderMatrix(const RenderOptions& options, const CommonOptions& common);
// --method progressive and stochastic. Sets *interrupted when a stop request ended the solver (the
// outputs and a checkpoint were written).
Status renderLightmapRadiosity(const RenderOptions& options, const CommonOptions& common,
                               bool* interrupted);
Status renderSss(const RenderOptions& options, const CommonOptions& common);
Status renderLpv(const RenderOptions& options, const CommonOptions& common);
// --method whitted and photons (render_whitted.cpp).
Status renderRayTraced(const RenderOptions& options, const CommonOptions& common);

// The name outputs are named after when none is given: "cornell" for a built-in scene, "room" for
// "scenes/room.json" (render's SCENE.png, bake's SCENE.gltf, ...).
std::string sceneStem(const std::string& scene);
// out.png -> out_0007.png: frame f of a sequence.
std::string sequenceFrameName(const std::string& path, int frame);
// Writes an image a method made (io/image_io.h: writeImage). A NaN or infinite pixel is a bug in
// the method, never a picture to hand on: it is an internal error (exit 1) naming the pixel.
Status writeMethodImage(const std::string& path, const Image& image,
                        const ToneMapSettings& tonemap = {});
// The render's image outputs (SCENE.png when none is given and the caller keeps no results), each
// checked before the work: a known format and a writable place; for a sequence of `frames` > 1
// its directory is made (and removed again if the run fails) and frame 0's name checked. The
// stats file is checked too.
Expected<std::vector<std::string>> checkRenderOutputs(const RenderOptions& options, int frames);

}  // namespace penumbra
