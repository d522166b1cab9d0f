#include "penumbra/methods/stats_file.h"

#include "penumbra/core/file_util.h"

#include <filesystem>
#include <fstream>

namespace penumbra {

Status writeStatsFile(const std::string& path, const nlohmann::json& stats) {
  return writeAtomically(path, [&](const std::string& tmp) -> Status {
    std::ofstream out(tmp);
    out << stats.dump(2) << "\n";
    out.close();
    if (!out) return runtimeError(path, "cannot write");
    return {};
  });
}

}  // namespace penumbra
