#include "penumbra/methods/stats_file.h"

#include "penumbra/core/file_util.h"

namespace penumbra {

Status writeStatsFile(const std::string& path, const nlohmann::json& stats) {
  return writeAtomically(path, [&](const std::string& tmp) -> Status {
    return writeBytesTo(path, tmp, stats.dump(2) + "\n");
  });
}

}  // namespace penumbra
