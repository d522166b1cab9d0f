#include "penumbra/core/memory.h"

#include <fmt/format.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <fstream>
#include <string>

namespace penumbra {

namespace {

// A number from a file that holds one ("max" or a missing file give nothing).
bool readNumber(const char* path, uint64_t* out) {
  std::ifstream in(path);
  std::string word;
  if (!(in >> word) || word.empty() || word.find_first_not_of("0123456789") != std::string::npos) {
    return false;
  }
  *out = std::stoull(word);
  return true;
}

// "MemAvailable:   123456 kB" from /proc/meminfo.
bool memAvailable(uint64_t* out) {
  std::ifstream in("/proc/meminfo");
  std::string key, unit;
  uint64_t kb = 0;
  while (in >> key >> kb) {
    std::getline(in, unit);
    if (key == "MemAvailable:") {
      *out = kb * 1024;
      return true;
    }
  }
  return false;
}

// The caller's budget (MemoryBudgetScope), 0 for none.
std::atomic<uint64_t> g_budget{0};

}  // namespace

MemoryBudgetScope::MemoryBudgetScope(uint64_t bytes) : previous_(g_budget.exchange(bytes)) {}

MemoryBudgetScope::~MemoryBudgetScope() {
  g_budget = previous_;
}

uint64_t physicalMemoryBytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES);
  const long page_size = ::sysconf(_SC_PAGE_SIZE);
  if (pages <= 0 || page_size <= 0) return uint64_t(8) << 30;
  return uint64_t(pages) * uint64_t(page_size);
}

MemoryBudget availableMemory() {
  MemoryBudget b;
  b.bytes = physicalMemoryBytes();
  b.limited_by = "physical memory";
  auto consider = [&](uint64_t bytes, const char* what) {
    if (bytes < b.bytes) {
      b.bytes = bytes;
      b.limited_by = what;
    }
  };
  uint64_t v = 0;
  if (memAvailable(&v)) consider(v, "MemAvailable");
  // The address-space limit (ulimit -v) less what this process already maps.
  rlimit rl{};
  if (::getrlimit(RLIMIT_AS, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY) {
    uint64_t pages = 0;
    std::ifstream statm("/proc/self/statm");
    statm >> pages;
    const uint64_t used = pages * uint64_t(::sysconf(_SC_PAGE_SIZE));
    consider(uint64_t(rl.rlim_cur) > used ? uint64_t(rl.rlim_cur) - used : 0, "ulimit -v");
  }
  // The control group's limit less its use (cgroup v2, then v1).
  uint64_t limit = 0, current = 0;
  if (readNumber("/sys/fs/cgroup/memory.max", &limit) &&
      readNumber("/sys/fs/cgroup/memory.current", &current)) {
    consider(limit > current ? limit - current : 0, "the cgroup's memory.max");
  } else if (readNumber("/sys/fs/cgroup/memory/memory.limit_in_bytes", &limit) &&
             readNumber("/sys/fs/cgroup/memory/memory.usage_in_bytes", &current) &&
             limit < (uint64_t(1) << 60)) {
    consider(limit > current ? limit - current : 0, "the cgroup's memory limit");
  }
  if (const uint64_t budget = g_budget.load(); budget > 0) consider(budget, "the caller's budget");
  return b;
}

std::string formatBytes(uint64_t bytes) {
  const double b = double(bytes);
  if (b >= double(1ull << 40)) return fmt::format("{:.1f} TiB", b / double(1ull << 40));
  if (b >= double(1ull << 30)) return fmt::format("{:.1f} GiB", b / double(1ull << 30));
  if (b >= double(1ull << 20)) return fmt::format("{:.1f} MiB", b / double(1ull << 20));
  if (b >= double(1ull << 10)) return fmt::format("{:.1f} KiB", b / double(1ull << 10));
  return fmt::format("{} bytes", bytes);
}

Status checkMemory(uint64_t bytes, const std::string& what) {
  const MemoryBudget available = availableMemory();
  // A margin for what the estimates leave out (the scene, the BVH, the allocator's slack).
  if (bytes > available.bytes / 10 * 9) {
    return inputError(
        "", "",
        fmt::format("{} needs {}, more than is available ({}, limited by {})", what,
                    formatBytes(bytes), formatBytes(available.bytes), available.limited_by));
  }
  return {};
}

}  // namespace penumbra
