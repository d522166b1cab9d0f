#include "penumbra/app/stats_file.h"

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

Status checkOutputPath(const std::string& path) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(path).parent_path();
  std::error_code ec;
  if (!dir.empty() && !fs::is_directory(dir, ec)) {
    return inputError(path, "", "the output directory '" + dir.string() + "' does not exist");
  }
  if (fs::is_directory(path, ec)) return inputError(path, "", "is a directory");
  return {};
}

}  // namespace penumbra
