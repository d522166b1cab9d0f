// The methods and their options, listed once (design doc sec. 2). The command line's options and
// --help, the checks of a scene file's "settings", `penumbra methods` and the option reference
// in docs/cli.md (a test keeps them equal) are all made from these descriptions.
#pragma once

#include "penumbra/cluster/communicator.h"
#include "penumbra/core/expected.h"
#include "penumbra/methods/command_options.h"
#include "penumbra/methods/option_spec.h"

#include <nlohmann/json_fwd.hpp>

#include <string>
#include <vector>

namespace penumbra {

struct MethodInfo {
  std::string name;     // --method NAME
  std::string summary;  // one line
  std::string source;   // the paper or the reason it is here
  bool bakes = false;   // `penumbra bake --method NAME` too
  // Shares its work over the ranks of an MPI job (docs/scaling.md): the others run on one process.
  bool over_ranks = false;
  // Its bake shares the work too (the path-traced bake runs on one process).
  bool bake_over_ranks = true;
};

// Every method `render` takes, in the order the docs list them.
const std::vector<MethodInfo>& methodInfos();
const MethodInfo* findMethod(const std::string& name);
// "pathtrace, whitted, ..." (bake: the methods that bake).
std::string methodNames(bool bake = false);

// Whether `command` (render, bake) runs `method` over the ranks of `comm`: the methods marked
// over_ranks do (and bake only those that bake); on more than one rank the others are refused,
// naming those that run there.
Status checkDistributedMethod(const Communicator& comm, const std::string& command,
                              const std::string& method);

// The options of `penumbra render` and `penumbra bake`, with the methods that take each.
const std::vector<OptionSpec>& renderOptionSpecs();
const std::vector<OptionSpec>& bakeOptionSpecs();
// The options of every command that does work (--threads, --quiet, --dry-run).
const std::vector<OptionSpec>& commonOptionSpecs();

// Sets the option `spec` (one of the command's specs) to `value`, already checked.
void setRenderOption(RenderOptions& options, const OptionSpec& spec, const OptionValue& value);
void setBakeOption(BakeOptions& options, const OptionSpec& spec, const OptionValue& value);
void setCommonOption(CommonOptions& options, const OptionSpec& spec, const OptionValue& value);

// Refuses an option `method` does not take, naming the option and the methods that do.
// `given` lists the options set (their names, without dashes), from whatever source.
Status checkOptionsTaken(const std::vector<OptionSpec>& specs, const std::string& method,
                         const std::vector<std::string>& given, const std::string& file = {},
                         const std::string& prefix = "--");

// A scene file's "settings": {"METHOD": {"option": value, ...}} for `method`, checked as the
// command line's values are (the same ranges, the same methods), with errors naming the file and
// "settings.METHOD.option". Options the command line set (`given`) win. Returns the names set.
Expected<std::vector<std::string>> applySceneSettings(RenderOptions& options,
                                                      const nlohmann::json& settings,
                                                      const std::string& file,
                                                      const std::vector<std::string>& given);
// The same for `bake`: the settings of the method it bakes that bake takes (the lightmap's and the
// solver's; the view's, such as width and spp, are render's alone).
Expected<std::vector<std::string>> applySceneSettings(BakeOptions& options,
                                                      const nlohmann::json& settings,
                                                      const std::string& file,
                                                      const std::vector<std::string>& given);

// The option reference of docs/cli.md (Markdown), made from the descriptions.
std::string optionReferenceMarkdown();

}  // namespace penumbra
