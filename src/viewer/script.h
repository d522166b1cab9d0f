// Scripted input for captures (`--script FILE`): a light path and a camera path, each a list of
// keys spread evenly over the frames of `--frames N` and followed linearly between them:
//
//   {"light": 0,
//    "light_path": [[-0.2, 0.25, -0.35], [0.2, 0.25, -0.35]],
//    "camera_path": [{"position": [0, 0.1, 0.4], "look_at": [0, 0.1, 0]}, ...]}
//
// "light" (default 0) is the index of the scene's light the light path moves. Either path may be
// left out; a path of one key holds still. "drop": {"frame": 1, "file": "room.gltf"} opens a
// file at that frame as if it had been dropped on the window.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/scene/camera.h"

#include <glm/vec3.hpp>

#include <optional>
#include <string>
#include <vector>

namespace penumbra::viewer {

struct CameraKey {
  glm::vec3 position{0.0f};
  glm::vec3 look_at{0.0f};
};

struct Script {
  int light = 0;
  std::vector<glm::vec3> light_path;
  std::vector<CameraKey> camera_path;
  int drop_frame = -1;  // the frame a file is dropped at, -1: none
  std::string drop_file;

  // Where the paths are at frame `frame` of `frames` (the first key at frame 0, the last at
  // frames - 1).
  std::optional<glm::vec3> lightAt(int frame, int frames) const;
  std::optional<CameraKey> cameraAt(int frame, int frames) const;
};

// Reads a script; errors name the file and the key.
Expected<Script> readScript(const std::string& path);

}  // namespace penumbra::viewer
