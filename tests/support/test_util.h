// Helpers shared by the tests.
#pragma once

#include "penumbra/core/expected.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

namespace penumbra::test {

// A fresh directory under the system temp dir, removed with its contents on destruction.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  // Writes `contents` to `name` inside the directory and returns its path.
  std::string write(const std::string& name, const std::string& contents) const;

 private:
  std::filesystem::path path_;
};

// Path of a file under tests/data.
inline std::string dataPath(const std::string& relative) {
  return std::string(PENUMBRA_TEST_DATA) + "/" + relative;
}

// Succeeds when `result` is an error whose description names `file` and `place`.
template <typename T>
::testing::AssertionResult errorNames(const Expected<T>& result, const std::string& file,
                                      const std::string& place) {
  if (result.ok()) return ::testing::AssertionFailure() << "loaded, but an error was expected";
  const std::string d = result.error().describe();
  if (d.find(file) == std::string::npos || d.find(place) == std::string::npos) {
    return ::testing::AssertionFailure()
           << "'" << d << "' does not name '" << file << "' and '" << place << "'";
  }
  return ::testing::AssertionSuccess() << d;
}

// Result of running the penumbra executable.
struct CliResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

// Runs build/bin/penumbra with `args` (a shell-quoted argument string).
CliResult runCli(const std::string& args);

}  // namespace penumbra::test
