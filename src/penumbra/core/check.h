// Contract checks. A failed PENUMBRA_CHECK is a bug in Penumbra, not bad input: it throws
// InternalError naming the expression, its location and the values involved, so that a program
// using the library (penumbra.h, the Python module) gets an error it can report and survive
// instead of a dead process; the CLI prints it and exits with 1. Bad input is reported through
// Expected<T> (see expected.h) instead.
#pragma once

#include <fmt/core.h>

#include <stdexcept>
#include <string>

namespace penumbra {

class InternalError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

namespace detail {
[[noreturn]] inline void checkFailed(const char* expr, const char* file, int line,
                                     const std::string& detail) {
  throw InternalError(fmt::format("internal error: check '{}' failed at {}:{}{}{}", expr, file,
                                  line, detail.empty() ? "" : ": ", detail));
}
}  // namespace detail

}  // namespace penumbra

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
