#pragma once
// Test code: a test binary that starts copies of itself as child processes.
// A test file declares what the child does for each mode:
//   RUMI_TEST_CHILD_MODES(int (*)(const std::string& mode));
// before main() runs, a process started with $RUMI_TEST_CHILD=<mode> runs
// that function and exits with its result; the parent starts such a child
// with ChildArgv() and ChildEnv("mode").
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

namespace rumi::testing {

inline std::vector<std::string> ChildArgv() {
  return {std::filesystem::read_symlink("/proc/self/exe").string()};
}
inline std::string ChildEnv(const std::string& mode) { return "RUMI_TEST_CHILD=" + mode; }

}  // namespace rumi::testing

#define RUMI_TEST_CHILD_MODES(fn)                                  \
  static const bool kRumiTestChildDispatch = [] {                  \
    if (const char* mode = std::getenv("RUMI_TEST_CHILD")) {       \
      ::_exit(fn(mode));                                           \
    }                                                              \
    return false;                                                  \
  }()
