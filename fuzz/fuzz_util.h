// Shared by the libFuzzer targets: the loaders read files, so each input is written to a file in
// a private directory (on /dev/shm where there is one) and loaded from there. Every target checks
// the loaders' contract: an input either loads or gives one input error naming the file; never
// a crash, a hang or an exception (ASan and UBSan are on).
#pragma once

#include "penumbra/core/expected.h"

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

namespace penumbra::fuzz {

inline const std::filesystem::path& workDir() {
  static const std::filesystem::path dir = [] {
    const std::filesystem::path base = std::filesystem::is_directory("/dev/shm")
                                           ? "/dev/shm"
                                           : std::filesystem::temp_directory_path();
    std::filesystem::path d = base / ("penumbra-fuzz-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

inline std::string writeInput(const std::string& name, std::string_view bytes) {
  const std::string path = (workDir() / name).string();
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), std::streamsize(bytes.size()));
  return path;
}

// The contract: success, or an input error that names a file (a crash or an exception aborts
// anyway). `R` is a
// Status or an Expected<T>.
template <typename R>
void expectContract(const R& result, const std::string& path) {
  if (result.ok()) return;
  const Error& e = result.error();
  if (e.kind != ErrorKind::kInput || e.message.empty() || e.file.empty()) {
    std::fprintf(stderr, "not an input error naming a file (%s): %s\n", path.c_str(),
                 e.describe().c_str());
    std::abort();
  }
}

}  // namespace penumbra::fuzz
