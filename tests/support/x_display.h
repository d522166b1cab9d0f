// A virtual X display for the viewer's tests: Xvfb (Debian's `xvfb`, with Mesa's GLX) started once
// per test process on a free display number and stopped when the process exits.
#pragma once

#include <string>

namespace penumbra::test {

// ":N" of the running Xvfb; empty (with `why`) when it cannot be started.
std::string xDisplay(std::string& why);

}  // namespace penumbra::test

namespace penumbra {
bool glRequired();
}

// Starts the test's X display, or skips the test when none can be started; under
// PENUMBRA_REQUIRE_GL=1 (CI) a missing display fails it instead.
#define PENUMBRA_DISPLAY_OR_SKIP(display)                    \
  std::string display;                                       \
  do {                                                       \
    std::string penumbra_why_;                               \
    display = ::penumbra::test::xDisplay(penumbra_why_);     \
    if (display.empty()) {                                   \
      if (::penumbra::glRequired()) FAIL() << penumbra_why_; \
      GTEST_SKIP() << "no X display: " << penumbra_why_;     \
    }                                                        \
  } while (false)
