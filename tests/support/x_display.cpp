#include "support/x_display.h"

#include <fmt/format.h>

#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <string>

#include <fcntl.h>
#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

namespace penumbra::test {

namespace {

pid_t xvfb_pid = 0;

void stopXvfb() {
  if (xvfb_pid > 0) {
    ::kill(xvfb_pid, SIGTERM);
    ::waitpid(xvfb_pid, nullptr, 0);
    xvfb_pid = 0;
  }
}

// Xvfb picks a free display and writes its number to the pipe (-displayfd).
std::string startXvfb(std::string& why) {
  int fds[2];
  if (::pipe(fds) != 0) {
    why = std::string("pipe: ") + std::strerror(errno);
    return {};
  }
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(fds[0]);
    const std::string fd = std::to_string(fds[1]);
    const int null = ::open("/dev/null", O_WRONLY);
    ::dup2(null, 1);
    ::dup2(null, 2);
    ::execlp("Xvfb", "Xvfb", "-displayfd", fd.c_str(), "-screen", "0", "1280x1024x24", "-nolisten",
             "tcp", "+extension", "GLX", static_cast<char*>(nullptr));
    ::_exit(127);
  }
  ::close(fds[1]);
  if (pid < 0) {
    ::close(fds[0]);
    why = std::string("fork: ") + std::strerror(errno);
    return {};
  }
  std::string number;
  pollfd p{fds[0], POLLIN, 0};
  while (number.find('\n') == std::string::npos && ::poll(&p, 1, 20000) > 0) {
    char buf[32];
    const ssize_t n = ::read(fds[0], buf, sizeof buf);
    if (n <= 0) break;
    number.append(buf, size_t(n));
  }
  ::close(fds[0]);
  const size_t end = number.find('\n');
  if (end == std::string::npos || end == 0) {
    ::kill(pid, SIGTERM);
    ::waitpid(pid, nullptr, 0);
    why = "Xvfb did not start (install the `xvfb` package: scripts/install-deps.sh)";
    return {};
  }
  xvfb_pid = pid;
  std::atexit(stopXvfb);
  return ":" + number.substr(0, end);
}

}  // namespace

std::string xDisplay(std::string& why) {
  static std::string failure;
  static const std::string display = startXvfb(failure);
  why = failure;
  return display;
}

}  // namespace penumbra::test
