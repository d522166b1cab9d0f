#include "penumbra/core/file_util.h"

#include "penumbra/core/memory.h"

#include <fmt/format.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <climits>
#include <csignal>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <system_error>

namespace penumbra {

namespace fs = std::filesystem;

namespace {

// What a file that is not a regular file is, for messages.
const char* kindOf(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

std::string notRegular(mode_t mode) {
  return fmt::format("is {}, not a regular file", kindOf(mode));
}

// An existing target that is not a regular file (nor a link, which rename replaces, not follows),
// or an empty string.
std::string unreplaceable(const std::string& path) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0 || S_ISREG(st.st_mode) || S_ISLNK(st.st_mode)) return {};
  return fmt::format("{}; only a regular file is replaced by an output", notRegular(st.st_mode));
}

OutputTransaction* g_current = nullptr;
std::atomic<unsigned> g_counter{0};
constexpr const char* kTempPrefix = ".penumbra-";

// A short temporary name beside `target` that keeps its extension (writers choose the format by
// it): ".penumbra-PID-N.ext". Short, so that any name that fits the file system has one that fits
// too.
fs::path temporaryFor(const fs::path& target) {
  return target.parent_path() / fmt::format("{}{}-{}{}", kTempPrefix, ::getpid(),
                                            g_counter.fetch_add(1), target.extension().string());
}

// Temporaries of processes that no longer exist (killed with SIGKILL, which nothing can catch)
// are removed when a later run writes into the same directory.
void removeStaleTemporaries(const fs::path& dir) {
  std::error_code ec;
  const fs::path where = dir.empty() ? fs::path(".") : dir;
  for (fs::directory_iterator it(where, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.rfind(kTempPrefix, 0) != 0) continue;
    const std::string rest = name.substr(std::string(kTempPrefix).size());
    size_t digits = 0;
    while (digits < rest.size() && std::isdigit(static_cast<unsigned char>(rest[digits]))) {
      ++digits;
    }
    if (digits == 0 || digits > 9 || digits >= rest.size() || rest[digits] != '-') continue;
    const long pid = std::stol(rest.substr(0, digits));
    if (pid == long(::getpid()) || ::kill(pid_t(pid), 0) == 0 || errno != ESRCH) continue;
    std::error_code rm;
    fs::remove_all(it->path(), rm);
  }
}

Status writeTemporary(const std::string& path,
                      const std::function<Status(const std::string&)>& write, fs::path* tmp,
                      CleanupOnSignal* guard) {
  const fs::path target(path);
  const fs::path dir = target.parent_path();
  std::error_code ec;
  if (!dir.empty() && !fs::is_directory(dir, ec)) {
    return runtimeError(path, "the directory '" + dir.string() + "' does not exist");
  }
  *tmp = temporaryFor(target);
  *guard = CleanupOnSignal(fs::absolute(*tmp, ec).string(), false);
  Status s = write(tmp->string());
  if (!s.ok()) {
    fs::remove(*tmp, ec);
    return s;
  }
  struct stat st {};
  if (::lstat(tmp->c_str(), &st) != 0 || !(S_ISREG(st.st_mode) || S_ISDIR(st.st_mode))) {
    fs::remove(*tmp, ec);
    return runtimeError(path, "cannot write: the writer left no file");
  }
  return {};
}

Status placeNow(const std::string& path, const fs::path& tmp) {
  std::error_code ec;
  if (const std::string why = unreplaceable(path); !why.empty()) {
    fs::remove(tmp, ec);
    return runtimeError(path, why);
  }
  fs::rename(tmp, path, ec);
  if (ec) {
    std::error_code rm;
    fs::remove(tmp, rm);
    return runtimeError(path, "cannot write: " + ec.message());
  }
  return {};
}

}  // namespace

Status writeAtomically(const std::string& path,
                       const std::function<Status(const std::string&)>& write) {
  fs::path tmp;
  CleanupOnSignal guard;
  PENUMBRA_TRY(writeTemporary(path, write, &tmp, &guard));
  if (g_current) {
    g_current->pending_.push_back({tmp.string(), path, std::move(guard)});
    return {};
  }
  return placeNow(path, tmp);
}

Status writeAtomicallyNow(const std::string& path,
                          const std::function<Status(const std::string&)>& write) {
  fs::path tmp;
  CleanupOnSignal guard;
  PENUMBRA_TRY(writeTemporary(path, write, &tmp, &guard));
  return placeNow(path, tmp);
}

OutputTransaction::OutputTransaction() {
  g_current = this;
}

OutputTransaction::~OutputTransaction() {
  if (g_current == this) g_current = nullptr;
  if (committed_) return;
  std::error_code ec;
  for (const Pending& p : pending_) fs::remove(p.tmp, ec);
  for (auto it = created_.rbegin(); it != created_.rend(); ++it) fs::remove(it->first, ec);
}

std::string OutputTransaction::pendingTemporary(const std::string& path) const {
  for (const Pending& p : pending_) {
    if (p.path == path) return p.tmp;
  }
  return {};
}

OutputTransaction* OutputTransaction::current() {
  return g_current;
}

namespace {
bool g_writes_outputs = true;
}  // namespace

void setThisProcessWritesOutputs(bool writes) {
  g_writes_outputs = writes;
}

bool thisProcessWritesOutputs() {
  return g_writes_outputs;
}

Status checkOutputPath(const std::string& path) {
  if (!g_writes_outputs) return {};
  const fs::path target(path);
  const fs::path dir = target.parent_path();
  std::error_code ec;
  if (!dir.empty() && !fs::is_directory(dir, ec)) {
    return inputError(path, "", "the output directory '" + dir.string() + "' does not exist");
  }
  if (fs::is_directory(target, ec)) return inputError(path, "", "is a directory");
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
    return inputError(
        path, "",
        fmt::format("{}; only a regular file is replaced by an output", notRegular(st.st_mode)));
  }
  const long name_max = ::pathconf(dir.empty() ? "." : dir.c_str(), _PC_NAME_MAX);
  const size_t limit = name_max > 0 ? size_t(name_max) : size_t(NAME_MAX);
  if (target.filename().string().size() > limit) {
    return inputError(path, "",
                      fmt::format("the file name is {} bytes long; this file system allows {}",
                                  target.filename().string().size(), limit));
  }
  removeStaleTemporaries(dir);
  // A probe with the temporary's name shape: the directory takes new files.
  const fs::path probe = temporaryFor(target);
  {
    std::ofstream out(probe, std::ios::binary);
    if (!out) {
      return inputError(path, "",
                        fmt::format("cannot write into the directory '{}'",
                                    dir.empty() ? std::string(".") : dir.string()));
    }
  }
  fs::remove(probe, ec);
  return {};
}

Status OutputTransaction::createDirectories(const std::string& dir) {
  if (!g_writes_outputs) return {};  // rank 0 makes them
  std::vector<fs::path> missing;
  std::error_code ec;
  for (fs::path p = fs::path(dir).lexically_normal(); !p.empty() && !fs::exists(p, ec);
       p = p.parent_path()) {
    missing.push_back(p);
    if (p == p.parent_path()) break;
  }
  for (auto it = missing.rbegin(); it != missing.rend(); ++it) {
    if (!fs::create_directory(*it, ec) || ec) {
      return inputError(dir, "", "cannot create the directory" + (ec ? ": " + ec.message() : ""));
    }
    created_.emplace_back(it->string(),
                          CleanupOnSignal(fs::absolute(*it, ec).string(), /*directory=*/true));
  }
  if (!fs::is_directory(dir, ec)) return inputError(dir, "", "is not a directory");
  return {};
}

void OutputTransaction::keepCreatedDirectories() {
  created_.clear();
}

Status OutputTransaction::commit() {
  PENUMBRA_TRY(placeSoFar());
  created_.clear();
  for (const std::string& p : remove_on_commit_) {
    std::error_code ec;
    fs::remove(p, ec);
  }
  committed_ = true;
  if (g_current == this) g_current = nullptr;
  return {};
}

Status OutputTransaction::placeSoFar() {
  std::vector<std::string> placed;
  for (size_t i = 0; i < pending_.size(); ++i) {
    std::error_code ec;
    const std::string why = unreplaceable(pending_[i].path);
    if (why.empty()) fs::rename(pending_[i].tmp, pending_[i].path, ec);
    if (ec || !why.empty()) {
      const Error e =
          runtimeError(pending_[i].path, !why.empty() ? why : "cannot write: " + ec.message());
      std::error_code rm;
      for (size_t j = i; j < pending_.size(); ++j) fs::remove(pending_[j].tmp, rm);
      for (const std::string& p : placed) fs::remove(p, rm);
      pending_.clear();
      return e;
    }
    placed.push_back(pending_[i].path);
  }
  pending_.clear();
  return {};
}

Status checkInputFile(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    if (errno == ENOENT || errno == ENOTDIR) return inputError(path, "", "no such file");
    return inputError(path, "", fmt::format("cannot open: {}", std::strerror(errno)));
  }
  if (!S_ISREG(st.st_mode)) return inputError(path, "", notRegular(st.st_mode));
  return {};
}

Expected<std::string> readFile(const std::string& path) {
  return readFile(path, std::numeric_limits<uint64_t>::max());
}

Expected<std::string> readFile(const std::string& path, uint64_t limit) {
  PENUMBRA_TRY(checkInputFile(path));
  // Opened without blocking (a FIFO put in place since the check would wait for a writer), then
  // checked again on the descriptor: what is read is what was checked.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return inputError(path, "", fmt::format("cannot open: {}", std::strerror(errno)));
  struct Close {
    int fd;
    ~Close() { ::close(fd); }
  } close_fd{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    return inputError(path, "", fmt::format("cannot open: {}", std::strerror(errno)));
  }
  if (!S_ISREG(st.st_mode)) return inputError(path, "", notRegular(st.st_mode));
  const uint64_t size = std::min(uint64_t(st.st_size), limit);
  PENUMBRA_TRY(checkMemory(size, fmt::format("reading '{}'", path)));
  std::string bytes;
  bytes.reserve(size_t(size));
  char buffer[1 << 16];
  while (bytes.size() < limit) {
    const ssize_t n =
        ::read(fd, buffer, size_t(std::min<uint64_t>(sizeof buffer, limit - bytes.size())));
    if (n == 0) break;
    if (n < 0) {
      if (errno == EINTR) continue;
      return inputError(path, "", fmt::format("read error: {}", std::strerror(errno)));
    }
    bytes.append(buffer, size_t(n));
    // A file that grows while it is read (a log being written) is read up to twice its size.
    if (bytes.size() > 2 * uint64_t(st.st_size) + sizeof buffer) {
      return inputError(path, "", "grew while it was read");
    }
  }
  return bytes;
}

Status writeBytesTo(const std::string& path, const std::string& tmp, std::string_view bytes) {
  // write() reports a full disk (ENOSPC) or a file-size limit (EFBIG) at once on local file
  // systems, and close() what a network file system found when flushing.
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd < 0) return runtimeError(path, fmt::format("cannot write: {}", std::strerror(errno)));
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : ENOSPC;
      ::close(fd);
      return runtimeError(path, fmt::format("cannot write: {}", std::strerror(err)));
    }
    done += size_t(n);
  }
  if (::close(fd) != 0) {
    return runtimeError(path, fmt::format("cannot write: {}", std::strerror(errno)));
  }
  return {};
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
