// Refusing work that will not fit: callers estimate the bytes they need before allocating.
#pragma once

#include "penumbra/core/expected.h"

#include <cstdint>
#include <string>

namespace penumbra {

// Physical memory of this machine in bytes.
uint64_t physicalMemoryBytes();

// "1.5 GiB", "12.0 MiB", ...
std::string formatBytes(uint64_t bytes);

// What this process may still allocate: the least of MemAvailable (/proc/meminfo), the
// address-space limit (ulimit -v) less what the process maps already, and its control group's
// memory.max less memory.current; with what set it.
struct MemoryBudget {
  uint64_t bytes = 0;
  const char* limited_by = "";
};
MemoryBudget availableMemory();

// A caller's own limit on what the work may allocate (methods/run_context.h: memory_budget), in
// force while the object lives: availableMemory() is then at most `bytes`, "limited by the
// caller's budget". 0 sets no limit. Scopes nest; the innermost one applies.
class MemoryBudgetScope {
 public:
  explicit MemoryBudgetScope(uint64_t bytes);
  ~MemoryBudgetScope();
  MemoryBudgetScope(const MemoryBudgetScope&) = delete;
  MemoryBudgetScope& operator=(const MemoryBudgetScope&) = delete;

 private:
  uint64_t previous_;
};

// An input error when `bytes` exceeds 90% of availableMemory(), naming `what`, both amounts and
// the limit that applies. Callers estimate from counts, before allocating.
Status checkMemory(uint64_t bytes, const std::string& what);

}  // namespace penumbra
