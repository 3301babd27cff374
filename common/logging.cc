#include "common/logging.h"

#include <spdlog/sinks/stdout_color_sinks.h>

namespace rumi {

bool SetupLogging(const std::string& process_name, const std::string& level) {
  auto logger = spdlog::get(process_name);  // again: a test, or SIGHUP
  if (!logger) {
    logger = spdlog::stderr_color_mt(process_name);
    logger->set_pattern("[%Y-%m-%d %H:%M:%S.%e] [%n] [%^%l%$] %v");
  }
  spdlog::set_default_logger(logger);
  const auto lvl = spdlog::level::from_str(level);
  // from_str returns "off" for unknown names; only accept "off" when asked.
  if (lvl == spdlog::level::off && level != "off") {
    spdlog::set_level(spdlog::level::info);
    spdlog::warn("unknown log level '{}', using info", level);
    return false;
  }
  spdlog::set_level(lvl);
  return true;
}

}  // namespace rumi
