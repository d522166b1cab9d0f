#include "support/test_util.h"

#include "penumbra/gpu/context.h"

#include <sys/wait.h>
#include <array>
#include <cstdio>
#include <fstream>
#include <random>

namespace penumbra::test {

TempDir::TempDir() {
  std::random_device rd;
  for (;;) {
    path_ = std::filesystem::temp_directory_path() /
            ("penumbra-test-" + std::to_string(rd()) + std::to_string(rd()));
    if (std::filesystem::create_directory(path_)) break;
  }
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

std::string TempDir::write(const std::string& name, const std::string& contents) const {
  const std::string p = file(name);
  std::ofstream out(p, std::ios::binary);
  out << contents;
  return p;
}

GlContext* glContext(std::string& why) {
  static std::string failure;
  static std::unique_ptr<GlContext> context = [] {
    Expected<std::unique_ptr<GlContext>> c = GlContext::createHeadless();
    if (!c) {
      failure = c.error().describe();
      return std::unique_ptr<GlContext>();
    }
    return std::move(*c);
  }();
  why = failure;
  if (context) context->makeCurrent();
  return context.get();
}

CliResult runCli(const std::string& args, const std::string& env) {
  CliResult result;
  const std::string cmd =
      (env.empty() ? "" : "env " + env + " ") + std::string(PENUMBRA_CLI) + " " + args + " 2>&1";
  FILE* pipe = ::popen(cmd.c_str(), "r");
  if (!pipe) return result;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = std::fread(buf.data(), 1, buf.size(), pipe)) > 0) result.output.append(buf.data(), n);
  const int status = ::pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

}  // namespace penumbra::test
