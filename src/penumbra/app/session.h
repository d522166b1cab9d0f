// A command run through the library's API (penumbra.h) instead of the command line: the scene
// comes from memory, what the command makes is handed back as well as written where the options
// say, and errors go back to the caller instead of stderr. The commands ask for these through the
// functions below, which do what the CLI does when no session is open.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/scene/scene.h"

#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace penumbra {

struct CommandSession {
  std::shared_ptr<const Scene> scene;  // what the command loads, whatever its name
  // Filled by the command.
  std::vector<Image> images;   // each image (frame) the command made, in order
  nlohmann::json stats;        // what --stats writes (null until the command made it)
  std::optional<Error> error;  // what the CLI would have printed

  // The open session (one at a time, process-wide), or null.
  static CommandSession* current();
};

// Opens `session` for as long as it lives.
class SessionScope {
 public:
  explicit SessionScope(CommandSession& session);
  ~SessionScope();
  SessionScope(const SessionScope&) = delete;
  SessionScope& operator=(const SessionScope&) = delete;
};

// The command's scene: the session's, else loadScene(name).
Expected<Scene> loadCommandScene(const std::string& name);
// The scene's "settings" (methods/registry.h: applySceneSettings) and the file they come from:
// the session's scene's, else the JSON file's (io/scene_io.h: readSceneSettings).
std::pair<nlohmann::json, std::string> commandSceneSettings(const std::string& name);
// Whether the command makes its statistics: a --stats file is named, or a session wants them.
bool wantsStats(const std::string& stats_path);
// Hands `stats` to the session and writes them to `path` when one is named.
Status emitStats(const std::string& path, const nlohmann::json& stats);
// Hands a finished image (a frame) to the session; nothing without one.
void emitImage(const Image& image);
// Whether a command without -o names its own output (SCENE.png): not in a session, whose caller
// takes the image in memory.
bool defaultsOutputs();

}  // namespace penumbra
