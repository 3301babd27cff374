#pragma once
// Helpers for tests that drive the `rumi` CLI as a user would.
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

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

}  // namespace test
}  // namespace rumi
