// `--stats FILE.json`: one JSON object per run, written atomically.
#pragma once

#include "penumbra/core/expected.h"

#include <nlohmann/json.hpp>

#include <string>

namespace penumbra {

Status writeStatsFile(const std::string& path, const nlohmann::json& stats);

// Checks before any work starts that an output path can be written: its directory exists.
Status checkOutputPath(const std::string& path);

}  // namespace penumbra
