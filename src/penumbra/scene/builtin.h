// Built-in scenes, available by name on the command line.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/scene/scene.h"

#include <string>
#include <vector>

namespace penumbra {

// "cornell": the Cornell box from the Cornell Program of Computer Graphics' published
//   measurements (millimetres, here metres), with the widely used RGB reflectances and light
//   radiance and the Cornell camera.
// "furnace": a closed 2 m cube seen from its centre; every surface has reflectance 0.5 and emits
//   radiance 1 from its inner face, so the exact radiance everywhere is E / (1 - rho) = 2.
// "sss": the Stanford bunny in marble lit from behind and the side (io/builtin_sss.cpp: loadScene
//   resolves it, as it needs the PLY reader).
std::vector<std::string> builtinSceneNames();
Expected<Scene> builtinScene(const std::string& name);

}  // namespace penumbra
