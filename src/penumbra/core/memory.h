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

// An input error when `bytes` exceeds 80% of physical memory, naming `what` and both amounts.
Status checkMemory(uint64_t bytes, const std::string& what);

}  // namespace penumbra
