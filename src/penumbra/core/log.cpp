#include "penumbra/core/log.h"

#include <spdlog/sinks/stdout_color_sinks.h>

namespace penumbra {

void initLogging(bool quiet) {
  static std::shared_ptr<spdlog::logger> logger = [] {
    auto l = spdlog::stderr_color_mt("penumbra");
    l->set_pattern("penumbra: %^%l%$: %v");
    spdlog::set_default_logger(l);
    return l;
  }();
  logger->set_level(quiet ? spdlog::level::warn : spdlog::level::info);
}

}  // namespace penumbra
