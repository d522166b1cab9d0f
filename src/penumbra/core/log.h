// Logging goes to stderr through spdlog; `--quiet` raises the level to warnings.
#pragma once

#include <spdlog/spdlog.h>

namespace penumbra {
// Sets up the stderr logger once; safe to call repeatedly.
void initLogging(bool quiet);
}  // namespace penumbra
