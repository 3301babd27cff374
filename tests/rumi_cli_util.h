#pragma once
// Helpers for tests that drive the `rumi` CLI and rumid as a user would
// (running, waiting and reading: common/testing/process.h).
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "common/testing/process.h"

namespace rumi {
namespace test {

// Runs `$RUMI_BIN_DIR/rumi ARGS`, stdout and stderr into log; exit code or -1.
inline int RunRumiLogged(const std::string& args, const std::filesystem::path& log) {
  return RunLogged(BinPath("rumi") + " " + args, log);
}

// A rumid state folder's status.json ({} while there is none or it is being replaced).
inline nlohmann::json ReadStatus(const std::filesystem::path& state) {
  try {
    return nlohmann::json::parse(Slurp(state / "status.json"));
  } catch (const std::exception&) {
    return nlohmann::json::object();
  }
}

// One child's entry in a status ({} when absent).
inline nlohmann::json StatusChild(const nlohmann::json& status, const std::string& name) {
  for (const auto& c : status.value("children", nlohmann::json::array()))
    if (c.value("name", std::string()) == name) return c;
  return nlohmann::json::object();
}

}  // namespace test
}  // namespace rumi
