#pragma once
// For tests only: what a test needs from outside the build (the real
// sequences in ../shared/data, COLMAP, an executable, a system tool). Where
// it is missing the test is skipped on a developer's machine, and fails
// under CI (CI=true, as .ci/run is run): a skip there would turn CI green
// without the check.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <sstream>

namespace rumi::test {

inline bool RequiredHere() {
  const char* ci = std::getenv("CI");
  return ci && (std::strcmp(ci, "true") == 0 || std::strcmp(ci, "1") == 0);
}

}  // namespace rumi::test

// RUMI_REQUIRE(condition, "what is missing" << detail);  in a TEST body or SetUp.
#define RUMI_REQUIRE(condition, message)                                                       \
  do {                                                                                         \
    if (!(condition)) {                                                                        \
      std::ostringstream rumi_require_message_;                                                \
      rumi_require_message_ << message;                                                        \
      if (::rumi::test::RequiredHere())                                                        \
        FAIL() << "required under CI (CI=true) and missing: " << rumi_require_message_.str(); \
      else                                                                                     \
        GTEST_SKIP() << rumi_require_message_.str();                                           \
    }                                                                                          \
  } while (0)
