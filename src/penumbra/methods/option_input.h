// A command's options from a program rather than the command line (design doc sec. 2): the API's
// string form (the command line's words, {"--spp", "64", "-o", "a.png"}) and named values (the
// typed API's and Python's keyword arguments, as JSON values: {"spp": 64}). Each value goes
// through its description's parse and range check (methods/option_spec.h) for the method the
// options name, and an option the method does not take is refused, exactly as on the command
// line: one validation path for every source.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/methods/command_options.h"

#include <nlohmann/json.hpp>

#include <string>
#include <utility>
#include <vector>

namespace penumbra {

// An option by name ("spp", "max-depth" or "max_depth") and its value.
using NamedValue = std::pair<std::string, nlohmann::json>;

template <typename Options>
struct CommandInput {
  Options options;
  CommonOptions common;
  std::vector<std::string> given;  // the names set (RunContext::given)
};
using RenderInput = CommandInput<RenderOptions>;
using BakeInput = CommandInput<BakeOptions>;

// The command's options from the command line's words (without the command and its scene, which
// the caller gives), onto `defaults`.
Expected<RenderInput> renderInputFromWords(const std::vector<std::string>& words,
                                           RenderOptions defaults = {});
Expected<BakeInput> bakeInputFromWords(const std::vector<std::string>& words,
                                       BakeOptions defaults = {});
// The same from named values. A repeatable option (-o) takes a string or an array of strings.
Expected<RenderInput> renderInputFromValues(const std::vector<NamedValue>& values,
                                            RenderOptions defaults = {});
Expected<BakeInput> bakeInputFromValues(const std::vector<NamedValue>& values,
                                        BakeOptions defaults = {});

}  // namespace penumbra
