#include "penumbra/core/file_util.h"

#include <unistd.h>
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

namespace penumbra {

namespace fs = std::filesystem;

Status writeAtomically(const std::string& path,
                       const std::function<Status(const std::string&)>& write) {
  fs::path target(path);
  fs::path dir = target.parent_path();
  std::error_code ec;
  if (!dir.empty() && !fs::is_directory(dir, ec)) {
    return runtimeError(path, "the directory '" + dir.string() + "' does not exist");
  }
  // Keep the extension so that writers which dispatch on it see the right one.
  fs::path tmp =
      dir / (".penumbra-tmp-" + std::to_string(::getpid()) + "-" + target.filename().string());
  Status s = write(tmp.string());
  if (!s.ok()) {
    fs::remove(tmp, ec);
    return s;
  }
  fs::rename(tmp, target, ec);
  if (ec) {
    fs::remove(tmp, ec);
    return runtimeError(path, "cannot write: " + ec.message());
  }
  return {};
}

Expected<std::string> readFile(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return inputError(path, "", "no such file");
  if (fs::is_directory(path, ec)) return inputError(path, "", "is a directory, not a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) return inputError(path, "", "cannot open for reading");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) return inputError(path, "", "read error");
  return ss.str();
}

std::string extensionOf(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

std::string resolveRelativeTo(const std::string& base_file, const std::string& path) {
  fs::path p(path);
  if (p.is_absolute()) return path;
  return (fs::path(base_file).parent_path() / p).lexically_normal().string();
}

}  // namespace penumbra
