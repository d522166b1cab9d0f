// A live session's settings as `render`'s options (methods/registry.h): which of them a live
// method takes, their values and their checks, from the same descriptions the command line, the
// API and Python use. The viewer builds its settings panel from these; LiveSession::create checks
// its settings and takes the scene's "settings" through resolveLiveSettings.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/interactive/live_session.h"
#include "penumbra/methods/option_spec.h"
#include "penumbra/scene/scene.h"

#include <vector>

namespace penumbra {

// The options a live session of `method` takes, in the order a panel shows them (spp, seed,
// elements, iterations, grid, steps: those `method` takes).
std::vector<const OptionSpec*> liveOptionSpecs(LiveMethod method);
// The option's value in `settings`, the method's default where the settings leave it to the
// method (0).
OptionValue liveOptionValue(const LiveSettings& settings, LiveMethod method,
                            const OptionSpec& spec);
// Sets the option after checking `value` against its description for `method` (the error names
// "--NAME" and the range).
Status setLiveOption(LiveSettings& settings, LiveMethod method, const OptionSpec& spec,
                     const OptionValue& value);
// `settings` with every option checked by its description and, where the settings leave one to
// the method, the scene's "settings" for it (checked as the command line's values are, errors
// naming the file and "settings.METHOD.NAME").
Expected<LiveSettings> resolveLiveSettings(const Scene& scene, LiveMethod method,
                                           LiveSettings settings);

}  // namespace penumbra
