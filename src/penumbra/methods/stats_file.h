// `--stats FILE.json`: one JSON object per run, written atomically.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/file_util.h"

#include <nlohmann/json.hpp>

#include <string>

namespace penumbra {

Status writeStatsFile(const std::string& path, const nlohmann::json& stats);

}  // namespace penumbra
