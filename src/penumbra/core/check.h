// Contract checks. A failed PENUMBRA_CHECK is a bug in Penumbra, not bad input: it prints the
// expression, its location and the values involved, then aborts. Bad input is reported through
// Expected<T> (see expected.h) instead.
#pragma once

#include <fmt/core.h>

#include <cstdio>
#include <cstdlib>

namespace penumbra::detail {
[[noreturn]] inline void checkFailed(const char* expr, const char* file, int line,
                                     const std::string& detail) {
  std::fprintf(stderr, "penumbra: internal error: check '%s' failed at %s:%d%s%s\n", expr, file,
               line, detail.empty() ? "" : ": ", detail.c_str());
  std::fflush(stderr);
  std::abort();
}
}  // namespace penumbra::detail

#define PENUMBRA_CHECK(cond)                                                     \
  do {                                                                           \
    if (!(cond)) ::penumbra::detail::checkFailed(#cond, __FILE__, __LINE__, ""); \
  } while (false)

// PENUMBRA_CHECK_MSG(cond, "fmt {}", values...) adds the values to the report.
#define PENUMBRA_CHECK_MSG(cond, ...)                                                         \
  do {                                                                                        \
    if (!(cond))                                                                              \
      ::penumbra::detail::checkFailed(#cond, __FILE__, __LINE__, ::fmt::format(__VA_ARGS__)); \
  } while (false)
