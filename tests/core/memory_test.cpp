// The memory guard counts what is available now: MemAvailable, the address-space limit
// (ulimit -v) and the control group's limit, and its refusal names the amounts and the limit.
#include "penumbra/core/memory.h"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <string>

namespace penumbra {
namespace {

TEST(Memory, AvailableIsAtMostPhysicalAndMemAvailable) {
  const MemoryBudget b = availableMemory();
  EXPECT_GT(b.bytes, 0u);
  EXPECT_LE(b.bytes, physicalMemoryBytes());
  std::ifstream in("/proc/meminfo");
  std::string key;
  uint64_t kb = 0;
  std::string unit;
  while (in >> key >> kb) {
    std::getline(in, unit);
    if (key == "MemAvailable:") break;
  }
  ASSERT_EQ(key, "MemAvailable:");
  // Within what another process may have taken or freed meanwhile.
  EXPECT_LE(b.bytes, kb * 1024 + (uint64_t(256) << 20));
  EXPECT_TRUE(checkMemory(uint64_t(1) << 20, "a small plan").ok());
  const Status huge = checkMemory(uint64_t(1) << 50, "a huge plan");
  ASSERT_FALSE(huge.ok());
  EXPECT_NE(huge.error().message.find("a huge plan needs 1024.0 TiB, more than is available"),
            std::string::npos)
      << huge.error().message;
}

TEST(Memory, TheAddressSpaceLimitIsCounted) {
  // In a child: ulimit -v at what the process maps now plus 512 MiB. The guard then offers about
  // 512 MiB, says so, and refuses 1 GiB.
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    uint64_t pages = 0;
    std::ifstream("/proc/self/statm") >> pages;
    const uint64_t mapped = pages * uint64_t(::sysconf(_SC_PAGE_SIZE));
    const rlimit rl{mapped + (uint64_t(512) << 20), RLIM_INFINITY};
    if (::setrlimit(RLIMIT_AS, &rl) != 0) ::_exit(10);
    const MemoryBudget b = availableMemory();
    // Within a MiB: the process may map a few pages more or less between the two reads (the
    // stream buffers come and go).
    if (b.bytes > (uint64_t(513) << 20)) ::_exit(11);
    if (std::string(b.limited_by) != "ulimit -v") ::_exit(12);
    const Status s = checkMemory(uint64_t(1) << 30, "a plan");
    if (s.ok() || s.error().message.find("limited by ulimit -v") == std::string::npos) ::_exit(13);
    ::_exit(0);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "10: setrlimit failed, 11: limit not counted, 12: not "
                                       "named, 13: not refused";
}

}  // namespace
}  // namespace penumbra
