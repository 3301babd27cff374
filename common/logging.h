#pragma once
// One logging setup for every rumi process: spdlog to stderr, process name in
// every line, level from config or CLI ("trace".."off").
#include <spdlog/spdlog.h>
#include <string>

namespace rumi {

// Returns false (and keeps "info") when level is not a known spdlog level.
// Calling it again (a test, a SIGHUP) only changes the level.
bool SetupLogging(const std::string& process_name, const std::string& level = "info");

}  // namespace rumi
