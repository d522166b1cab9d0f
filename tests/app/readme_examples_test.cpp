// Every example in the README's Examples block runs as written (from a copy of the repository's
// layout): the lines whose outputs later lines read (ray files, the checkpoint Ctrl-C leaves) run
// for real, `info` runs as is, and every other line runs with --dry-run, which must succeed and
// leave the directory exactly as it was.
#include "support/test_util.h"

#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace penumbra {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

struct Example {
  std::string args;     // after "$B "
  std::string comment;  // after "#", if any
};

std::vector<Example> readmeExamples() {
  std::ifstream in(std::string(PENUMBRA_SOURCE_DIR) + "/README.md");
  std::string line;
  bool in_section = false, in_block = false;
  std::vector<Example> examples;
  while (std::getline(in, line)) {
    if (line.rfind("## ", 0) == 0) in_section = line == "## Examples";
    if (!in_section) continue;
    if (line.rfind("```", 0) == 0) {
      if (in_block) break;
      in_block = true;
      continue;
    }
    if (!in_block || line.rfind("$B ", 0) != 0) continue;
    Example e;
    const size_t hash = line.find(" #");
    e.args = line.substr(3, hash == std::string::npos ? std::string::npos : hash - 3);
    while (!e.args.empty() && e.args.back() == ' ') e.args.pop_back();
    if (hash != std::string::npos) e.comment = line.substr(hash + 2);
    examples.push_back(e);
  }
  return examples;
}

std::vector<std::string> words(const std::string& s) {
  std::vector<std::string> out;
  std::istringstream in(s);
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

// Every file and directory under `dir` (symbolic links not followed), relative.
std::set<std::string> listing(const fs::path& dir) {
  std::set<std::string> names;
  for (auto it = fs::recursive_directory_iterator(dir); it != fs::recursive_directory_iterator();
       ++it) {
    names.insert(fs::relative(it->path(), dir).string());
  }
  return names;
}

// Runs the CLI in `dir`; with `interrupt_after`, sends SIGINT once that text has appeared in its
// output. The exit status as a shell gives it, and the output.
test::CliResult runIn(const fs::path& dir, const std::string& args,
                      const std::string& interrupt_after = "") {
  std::vector<std::string> argv_words = words(args);
  argv_words.insert(argv_words.begin(), PENUMBRA_CLI);
  std::vector<char*> argv;
  for (std::string& w : argv_words) argv.push_back(w.data());
  argv.push_back(nullptr);
  int pipe_fds[2];
  if (::pipe(pipe_fds) != 0) return {};
  const pid_t pid = ::fork();
  if (pid == 0) {
    if (::chdir(dir.c_str()) != 0) ::_exit(127);
    ::dup2(pipe_fds[1], 1);
    ::dup2(pipe_fds[1], 2);
    ::close(pipe_fds[0]);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  ::close(pipe_fds[1]);
  test::CliResult result;
  bool sent = false;
  std::array<char, 4096> buf;
  for (ssize_t n; (n = ::read(pipe_fds[0], buf.data(), buf.size())) > 0;) {
    result.output.append(buf.data(), size_t(n));
    if (!interrupt_after.empty() && !sent &&
        result.output.find(interrupt_after) != std::string::npos) {
      ::kill(pid, SIGINT);
      sent = true;
    }
  }
  ::close(pipe_fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  result.exit_code = WIFEXITED(status)     ? WEXITSTATUS(status)
                     : WIFSIGNALED(status) ? 128 + WTERMSIG(status)
                                           : -1;
  return result;
}

TEST(Readme, EveryExampleRunsAsWritten) {
  const std::vector<Example> examples = readmeExamples();
  ASSERT_GE(examples.size(), 15u) << "the README's Examples block was not found";
  TempDir dir;
  for (const char* tree : {"scenes", "tests"}) {
    fs::create_directory_symlink(fs::path(PENUMBRA_SOURCE_DIR) / tree, dir.path() / tree);
  }
  for (size_t i = 0; i < examples.size(); ++i) {
    const Example& e = examples[i];
    SCOPED_TRACE("README example: penumbra " + e.args);
    const std::vector<std::string> w = words(e.args);
    ASSERT_FALSE(w.empty());
    // Does a later example read what this one writes?
    bool feeds_later = false;
    for (size_t k = 0; k + 1 < w.size(); ++k) {
      if (w[k] != "-o") continue;
      for (size_t j = i + 1; j < examples.size(); ++j) {
        feeds_later |= examples[j].args.find(w[k + 1]) != std::string::npos;
      }
    }
    if (w[0] == "info") {
      const test::CliResult r = runIn(dir.path(), e.args);
      EXPECT_EQ(r.exit_code, 0) << r.output;
    } else if (feeds_later && e.comment.find("Ctrl-C") != std::string::npos) {
      // As a user would: Ctrl-C once the solve runs; a checkpoint is left for --resume.
      const test::CliResult r = runIn(dir.path(), e.args, "lightmap texels in a");
      EXPECT_EQ(r.exit_code, 130) << r.output;
      EXPECT_NE(r.output.find("checkpoint written"), std::string::npos) << r.output;
    } else if (feeds_later) {
      const test::CliResult r = runIn(dir.path(), e.args);
      EXPECT_EQ(r.exit_code, 0) << r.output;
    } else {
      const std::set<std::string> before = listing(dir.path());
      const std::string args =
          e.args.find("--dry-run") == std::string::npos ? e.args + " --dry-run" : e.args;
      const test::CliResult r = runIn(dir.path(), args);
      EXPECT_EQ(r.exit_code, 0) << r.output;
      EXPECT_NE(r.output.find("dry run: options, inputs, output paths and memory are fine"),
                std::string::npos)
          << r.output;
      EXPECT_EQ(listing(dir.path()), before) << "a dry run left files behind";
    }
  }
}

}  // namespace
}  // namespace penumbra
