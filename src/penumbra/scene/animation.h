// Scenes that change over time, for frame sequences (`render --frames N`): the scene at time t in
// [0, 1), frame f of N at t = f / N. Meshes may change their vertices, triangles and topology
// from one time to the next; the list of meshes and materials stays.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/scene/scene.h"

#include <functional>
#include <optional>
#include <string>

namespace penumbra {

using SceneAnimation = std::function<Expected<Scene>(double t)>;

// The built-in animations: "blobs" (two translucent (jade-like) blobs that move together and merge,
// one mesh whose topology changes from two components to one, over a floor, lit from the side).
// None for another name.
std::optional<SceneAnimation> builtinAnimation(const std::string& name);

}  // namespace penumbra
