#include "penumbra/core/memory.h"

#include <fmt/format.h>
#include <unistd.h>

namespace penumbra {

uint64_t physicalMemoryBytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES);
  const long page_size = ::sysconf(_SC_PAGE_SIZE);
  if (pages <= 0 || page_size <= 0) return uint64_t(8) << 30;
  return uint64_t(pages) * uint64_t(page_size);
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
  const uint64_t available = physicalMemoryBytes();
  if (bytes > available / 10 * 8) {
    return inputError("", "",
                      fmt::format("{} needs {}, more than this machine can give ({} of memory)",
                                  what, formatBytes(bytes), formatBytes(available)));
  }
  return {};
}

}  // namespace penumbra
