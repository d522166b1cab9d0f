// `penumbra view`: a GLFW window with an OpenGL 4.5 context showing one method live on a scene
// (interactive/live_session.h), with Dear ImGui panels for the method, the lights, the materials,
// the exposure and the frame times. The window is a front end only: every solver, option and
// default is the library's, so that `penumbra render` computes headless what the window shows.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/io/tonemap.h"
#include "penumbra/subsurface/lpv.h"

#include <cstdint>
#include <string>

namespace penumbra::viewer {

struct ViewerOptions {
  std::string scene = "cornell";
  std::string method = "pathtrace";
  int width = 1120, height = 640;  // the window's size in pixels (the image: less the side panel)
  int spp = 0;                     // 0: the method's default (interactive/live_session.h)
  uint64_t seed = 0;
  uint32_t elements = 0;
  // cpu, gpu, or auto: the GPU twins (matrix, sss, lpv) when the window's OpenGL is hardware, as
  // `render --device auto` chooses.
  std::string device = "auto";
  int iterations = 0;
  LpvOptions lpv;
  ToneMapSettings tonemap;
  // Captures: after `frames` frames (each frame's work finished before the next, the script
  // applied at each), the window is written to `screenshot` and the viewer exits.
  std::string script;
  std::string screenshot;
  int frames = 0;
  bool sequence = false;  // write every frame (name_0000.png, ...) instead of the last only
  bool hide_ui = false;   // the image alone, without panels or light markers
  // Captures as the window runs: each frame works within `budget` instead of finishing (to
  // measure the frame rate a person gets).
  bool live = false;
  std::string stats;           // capture: per-frame times and the frame rate (JSON)
  double budget = 1.0 / 60.0;  // seconds of solver work per frame
};

// Runs the viewer until its window closes (or the capture is written). Errors before the window
// opens (bad options, no display) come back as values; errors in the window are shown there.
Status runViewer(const ViewerOptions& options);

}  // namespace penumbra::viewer
