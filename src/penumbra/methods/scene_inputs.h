// What `render` and `bake` do to the scene they were given before a method runs on it
// (command_options.h: SceneInputOptions; docs/cli.md):
//   - --scale: every length of the scene (geometry, light positions, the camera, calculation
//     objects, openings) times metres per unit, so that lightmap density, inverse-square light
//     and lux are right for a file exported in millimetres or inches;
//   - --sky: a CIE standard sky with its ground (and, for "sunny", the sun's beam) for a scene
//     that brings no light, as a viewer lights a model; --environment: a uniform environment;
//   - a warning when the scene is kilometres across or a few centimetres small: probably in the
//     wrong unit. (A scene that emits no light at all is refused by every method alike:
//     scene/scene.h, noLightError.)
// The library's render and bake call it, so the command line, the API and Python agree.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/methods/command_options.h"
#include "penumbra/methods/run_context.h"
#include "penumbra/scene/scene.h"

#include <memory>
#include <string>

namespace penumbra {

// How to read the scene: the files it may name, its textures' limits, a glTF file's scene;
// `dry_run` plans textures without decoding them.
SceneLoadOptions sceneLoadOptions(const SceneInputOptions& in, bool dry_run);

// `scene` with the inputs applied (the same scene when there are none), and the warnings above
// added to its own.
Expected<std::shared_ptr<const Scene>> applySceneInputs(std::shared_ptr<const Scene> scene,
                                                        const SceneInputOptions& in);

// The run `render` or `bake` makes of `context`: the scene's "settings" applied to `options` first
// (they may set the scene's inputs), then the inputs to the scene; `options.given` becomes the
// options the command line gave and those the settings set.
Expected<RunContext> prepareRun(RenderOptions& options, const RunContext& context);
Expected<RunContext> prepareRun(BakeOptions& options, const RunContext& context);

// A warning when the scene is probably not in metres (kilometres across, or centimetres small).
std::vector<std::string> unitWarnings(const Scene& scene);
// Those, and one when the scene emits no light (which every method refuses): what `info` says.
std::vector<std::string> firstPictureWarnings(const Scene& scene);

}  // namespace penumbra
