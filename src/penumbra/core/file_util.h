// Files: outputs are written to a temporary name beside the target and renamed into place, so a
// failed or interrupted run never leaves a partial output file.
#pragma once

#include "penumbra/core/expected.h"

#include <functional>
#include <string>

namespace penumbra {

// Calls write(tmp_path); on success renames tmp_path to `path`, otherwise removes it.
Status writeAtomically(const std::string& path,
                       const std::function<Status(const std::string&)>& write);

// Reads a whole file into a string (binary).
Expected<std::string> readFile(const std::string& path);

// Lower-case extension with the dot (".exr"), empty when none.
std::string extensionOf(const std::string& path);

// `path` resolved against the directory of `base_file` unless it is absolute.
std::string resolveRelativeTo(const std::string& base_file, const std::string& path);

}  // namespace penumbra
