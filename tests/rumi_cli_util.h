#pragma once
// Helpers for tests that drive the `rumi` CLI as a user would.
#include <signal.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

namespace rumi {
namespace test {

// Runs `$RUMI_BIN_DIR/rumi ARGS`, stdout and stderr into log; exit code or -1.
inline int RunRumiLogged(const std::string& args, const std::filesystem::path& log) {
  const char* bin = std::getenv("RUMI_BIN_DIR");
  const std::string cmd = std::string(bin ? bin : ".") + "/rumi " + args + " > " + log.string() + " 2>&1";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

inline std::string Slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// A rumi executable of this build ($RUMI_BIN_DIR, set by ctest).
inline std::string BinPath(const std::string& name) {
  const char* dir = std::getenv("RUMI_BIN_DIR");
  return (std::filesystem::path(dir ? dir : RUMI_BINARY_DIR "/bin") / name).string();
}

inline double SecondsSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// Exit code of child pid, -2 when killed by a signal, -1 when it is still
// running after timeout_s (then SIGKILLed and reaped with kill_on_timeout).
inline int WaitExit(pid_t pid, double timeout_s, bool kill_on_timeout = false) {
  const auto t0 = std::chrono::steady_clock::now();
  int st = 0;
  while (SecondsSince(t0) < timeout_s) {
    if (::waitpid(pid, &st, WNOHANG) == pid) return WIFEXITED(st) ? WEXITSTATUS(st) : -2;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  if (kill_on_timeout) {
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &st, 0);
  }
  return -1;
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
