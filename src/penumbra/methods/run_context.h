// What a method's run gets from its caller and gives back (docs/architecture.md): the CLI, the
// public API, Python and MPI jobs all run a method the same way, through renderScene / bakeScene
// (methods/render.h) with a RunContext, and differ only in the context they pass.
//
// The context is explicit at the entry points; for the run's duration RunScope makes it the
// current one, so that the methods' steps reach it (RunScope::current()) without every helper
// taking it as a parameter, as the communicator (cluster/communicator.h: CommunicatorScope) and
// the output transaction (core/file_util.h) already are.
#pragma once

#include "penumbra/cluster/communicator.h"
#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/progress.h"
#include "penumbra/methods/command_options.h"
#include "penumbra/scene/scene.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace penumbra {

struct RunContext {
  // The scene the method runs on. Its "settings" (methods/registry.h: applySceneSettings) fill in
  // the options the caller did not set.
  std::shared_ptr<const Scene> scene;
  // The options the caller set itself (their names without dashes, "spp"): the scene's settings
  // do not replace these.
  std::vector<std::string> given;
  // Progress (stage, fraction in [0, 1]) besides the terminal's bar, from any thread; at most a
  // few times a second per stage.
  std::function<void(const std::string& stage, double fraction)> progress;
  // A stop request (core/interrupt.h: requestInterrupt, or SIGINT / SIGTERM under the CLI) ends the
  // run: progressive and stochastic radiosity at their next step, with their solution and a
  // checkpoint written (RunResult::interrupted); the other methods at their next progress step,
  // with Interrupted thrown and nothing written. Without it (the CLI), a signal outside a clean
  // stopping point ends the process, removing partial outputs.
  bool stop_on_request = false;
  // The most the run may allocate, bytes (0: what the machine has). Every plan is checked against
  // the smaller of this and the machine's before anything is allocated (core/memory.h).
  uint64_t memory_budget = 0;
  // The processes the run is shared over (null: the current communicator, by default this process
  // alone). Every rank makes the same call; rank 0 gets the results and writes the files.
  Communicator* communicator = nullptr;
  // Results: hand the images and the statistics back in RunResult (as well as writing the files
  // the options name). Without it a render with no -o writes SCENE.png, as the CLI does.
  bool keep_results = false;
};

struct RunResult {
  std::vector<Image> images;  // each image (frame) made, in order (keep_results)
  nlohmann::json stats;       // what --stats writes (keep_results, or --stats given)
  bool interrupted = false;   // stopped cleanly at a request, with its outputs written
};

// The context of the run in progress on this process, made current by the entry points.
class RunScope {
 public:
  // Installs `context` (its progress, stop and memory settings, its communicator).
  explicit RunScope(const RunContext& context);
  ~RunScope();
  RunScope(const RunScope&) = delete;
  RunScope& operator=(const RunScope&) = delete;

  const RunContext& context() const { return context_; }
  RunResult& result() { return result_; }
  const Scene& scene() const { return *context_.scene; }

  // The open scope, or null.
  static RunScope* current();

 private:
  const RunContext& context_;
  RunResult result_;
  ProgressObserver observer_;
  std::optional<CommunicatorScope> communicator_;
  std::optional<MemoryBudgetScope> budget_;
  RunScope* previous_ = nullptr;
};

// A run of a method: `run(&interrupted)` inside a RunScope for `context`, on common.threads
// threads (0: every core, shared among the ranks of this machine), and in an output transaction
// (core/file_util.h), so that every output is placed at the end, together, or none is; with
// common.dry_run nothing is placed. Returns what the run handed back through the scope.
Expected<RunResult> runInScope(const RunContext& context, const CommonOptions& common,
                               const std::function<Status(bool* interrupted)>& run);

// The run's scene: the current scope's (methods run only inside one).
const Scene& runScene();
// Whether the run makes its statistics: a --stats file is named, or the caller keeps them.
bool wantsStats(const std::string& stats_path);
// Hands `stats` to the caller and writes them to `path` when one is named.
Status emitStats(const std::string& path, const nlohmann::json& stats);
// Hands a finished image (a frame) to the caller when it keeps results.
void emitImage(const Image& image);
// Whether a render without -o names its own output (SCENE.png): not when the caller keeps the
// image in memory.
bool defaultsOutputs();

}  // namespace penumbra
