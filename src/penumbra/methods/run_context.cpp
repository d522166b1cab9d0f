#include "penumbra/methods/run_context.h"

#include "penumbra/core/check.h"
#include "penumbra/core/file_util.h"
#include "penumbra/core/parallel.h"
#include "penumbra/methods/stats_file.h"

#include <atomic>

namespace penumbra {

namespace {
std::atomic<RunScope*> g_run{nullptr};
}  // namespace

RunScope::RunScope(const RunContext& context) : context_(context), previous_(g_run.load()) {
  PENUMBRA_CHECK(context.scene != nullptr);
  if (context.communicator) communicator_.emplace(*context.communicator);
  if (context.progress || context.stop_on_request) {
    observer_.report = context.progress;
    observer_.stop_on_interrupt = context.stop_on_request;
    setProgressObserver(&observer_);
  }
  if (context.memory_budget > 0) budget_.emplace(context.memory_budget);
  g_run = this;
}

RunScope::~RunScope() {
  g_run = previous_;
  if (context_.progress || context_.stop_on_request) setProgressObserver(nullptr);
}

RunScope* RunScope::current() {
  return g_run.load();
}

Expected<RunResult> runInScope(const RunContext& context, const CommonOptions& common,
                               const std::function<Status(bool* interrupted)>& run) {
  RunScope scope(context);
  const auto thread_limit = limitThreads(threadsPerRank(currentCommunicator(), common.threads));
  OutputTransaction transaction;
  bool interrupted = false;
  PENUMBRA_TRY(run(&interrupted));
  if (common.dry_run) return RunResult{};  // the transaction removes what it made
  PENUMBRA_TRY(transaction.commit());
  RunResult result = std::move(scope.result());
  result.interrupted = interrupted;
  return result;
}

const Scene& runScene() {
  RunScope* run = RunScope::current();
  PENUMBRA_CHECK(run != nullptr);
  return run->scene();
}

bool wantsStats(const std::string& stats_path) {
  if (!stats_path.empty()) return true;
  RunScope* run = RunScope::current();
  return run && run->context().keep_results;
}

Status emitStats(const std::string& path, const nlohmann::json& stats) {
  if (RunScope* run = RunScope::current()) run->result().stats = stats;
  if (path.empty()) return {};
  return writeStatsFile(path, stats);
}

void emitImage(const Image& image) {
  RunScope* run = RunScope::current();
  if (run && run->context().keep_results) run->result().images.push_back(image);
}

bool defaultsOutputs() {
  RunScope* run = RunScope::current();
  return !run || !run->context().keep_results;
}

}  // namespace penumbra
