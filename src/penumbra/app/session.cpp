#include "penumbra/app/session.h"

#include "penumbra/app/stats_file.h"
#include "penumbra/io/scene_io.h"

#include <atomic>

namespace penumbra {

namespace {
std::atomic<CommandSession*> g_session{nullptr};
}  // namespace

CommandSession* CommandSession::current() {
  return g_session.load();
}

SessionScope::SessionScope(CommandSession& session) {
  g_session = &session;
}

SessionScope::~SessionScope() {
  g_session = nullptr;
}

Expected<Scene> loadCommandScene(const std::string& name) {
  if (CommandSession* s = CommandSession::current(); s && s->scene) return Scene(*s->scene);
  return loadScene(name);
}

std::pair<nlohmann::json, std::string> commandSceneSettings(const std::string& name) {
  if (CommandSession* s = CommandSession::current(); s && s->scene) {
    return {s->scene->settings, s->scene->source};
  }
  return {readSceneSettings(name), name};
}

bool wantsStats(const std::string& stats_path) {
  return !stats_path.empty() || CommandSession::current() != nullptr;
}

Status emitStats(const std::string& path, const nlohmann::json& stats) {
  if (CommandSession* s = CommandSession::current()) s->stats = stats;
  if (path.empty()) return {};
  return writeStatsFile(path, stats);
}

void emitImage(const Image& image) {
  if (CommandSession* s = CommandSession::current()) s->images.push_back(image);
}

bool defaultsOutputs() {
  return CommandSession::current() == nullptr;
}

}  // namespace penumbra
