// `penumbra render` and `penumbra bake` on the command line: the scene loaded, the library's run
// called (methods/render.h), its error printed. How a method runs is the library's.
#include "penumbra/app/commands.h"
#include "penumbra/cluster/communicator.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/methods/scene_inputs.h"

#include <memory>

namespace penumbra {

namespace {

// The command's scene, loaded on every rank of an MPI job (each agrees it has it before any
// goes on, so that a rank that cannot read the file stops the job instead of leaving the others
// waiting).
Expected<std::shared_ptr<const Scene>> loadCommandScene(const std::string& name,
                                                        const SceneLoadOptions& options) {
  Expected<Scene> scene = loadScene(name, options);
  Communicator& comm = currentCommunicator();
  if (comm.distributed()) {
    PENUMBRA_TRY(agreeReady(comm, scene ? Status{} : Status(scene.error())));
  }
  if (!scene) return scene.error();
  return std::make_shared<const Scene>(std::move(*scene));
}

// Loads the command's scene and runs `run` (renderScene or bakeScene) on it: the exit code.
template <typename Options, typename Run>
int runCommand(Options options, const CommonOptions& common, const std::vector<std::string>& given,
               Run run) {
  Expected<std::shared_ptr<const Scene>> scene =
      loadCommandScene(options.scene, sceneLoadOptions(options, common.dry_run));
  if (!scene) return reportError(scene.error());
  RunContext context;
  context.scene = *scene;
  context.given = given;
  const Expected<RunResult> result = run(std::move(options), common, context);
  if (!result) return reportError(result.error());
  if (common.dry_run) return reportDryRun();
  return result->interrupted ? InterruptScope::exitCode() : 0;
}

}  // namespace

int runRender(RenderOptions options, const CommonOptions& common,
              const std::vector<std::string>& given) {
  return runCommand(std::move(options), common, given, &renderScene);
}

int runBake(const BakeOptions& options, const CommonOptions& common,
            const std::vector<std::string>& given) {
  return runCommand(options, common, given, &bakeScene);
}

}  // namespace penumbra
